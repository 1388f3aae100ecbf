//! The OBJ text parsed in chunks on all threads: split at line boundaries
//! (never inside a continued line), each chunk parsed on its own with its
//! `o`/`g`/`usemtl` statements kept and its relative indices kept relative
//! to the chunk's start, then put together in order. The result is the one
//! pass's whatever the chunks and threads; a file the chunks cannot read
//! (a malformed line, an index out of range, bytes that are not UTF-8) is
//! read again in one pass, which gives its error as it always did.

use super::*;
use rayon::prelude::*;

/// The size of a chunk of text (bytes, up to the end of a line).
pub(super) const CHUNK_BYTES: usize = 1 << 20;

/// A chunk's `o`, `g` and `usemtl` statement (`None`: no name).
#[derive(Debug)]
pub(super) enum Event {
    Object(Option<String>),
    Group(Option<String>),
    Material(Option<String>),
}

/// Marks a relative index in a chunk: the low bits hold its offset from
/// the chunk's first element plus [`BIAS`].
pub(super) const REL: u32 = 1 << 31;
const BIAS: i64 = 1 << 30;

/// Parse OBJ `bytes` (the file's `stem` naming its first object) in chunks
/// of about `chunk` bytes; lossy UTF-8.
pub(super) fn prepare(bytes: &[u8], stem: &str, chunk: usize) -> Result<Prepared, ObjError> {
    let chunks = split(bytes, chunk);
    let parsed: Option<Vec<Prepared>> = if chunks.len() > 1 {
        chunks
            .par_iter()
            .map(|c| parse_chunk(std::str::from_utf8(c).ok()?))
            .collect()
    } else {
        chunks
            .iter()
            .map(|c| parse_chunk(std::str::from_utf8(c).ok()?))
            .collect()
    };
    if let Some(p) = parsed.and_then(|p| merge(p, stem)) {
        return Ok(p);
    }
    match String::from_utf8_lossy(bytes) {
        // Valid now: read in chunks too.
        std::borrow::Cow::Owned(text) => prepare(text.as_bytes(), stem, chunk),
        std::borrow::Cow::Borrowed(text) => preprocess(text, stem),
    }
}

/// `bytes` cut after a newline about every `size` bytes, where the line
/// before does not continue (does not end with `\`, nor with a byte that
/// is not ASCII, which could be trailing white space).
fn split(bytes: &[u8], size: usize) -> Vec<&[u8]> {
    let mut out = Vec::new();
    let mut start = 0;
    let mut from = start + size.max(1) - 1;
    while start < bytes.len() {
        let Some(nl) = bytes
            .get(from..)
            .and_then(|b| b.iter().position(|&c| c == b'\n'))
        else {
            out.push(&bytes[start..]);
            break;
        };
        let nl = from + nl;
        let line_start = bytes[start..nl]
            .iter()
            .rposition(|&c| c == b'\n')
            .map_or(start, |k| start + k + 1);
        let line = bytes[line_start..nl].trim_ascii_end();
        if matches!(line.last(), Some(&c) if c == b'\\' || !c.is_ascii()) {
            from = nl + 1;
            continue;
        }
        out.push(&bytes[start..=nl]);
        start = nl + 1;
        from = start + size.max(1) - 1;
    }
    out
}

/// One chunk parsed on its own, or `None` when something in it is wrong.
fn parse_chunk(text: &str) -> Option<Prepared> {
    let mut p = Prepared {
        events: Some(Vec::new()),
        ..Default::default()
    };
    let mut state = Section {
        object: 0,
        group: None,
        material: None,
    };
    logical_lines(text, |line, no| p.line(line, no, "", &mut state)).ok()?;
    Some(p)
}

/// A face index in a chunk with `count` elements of its kind so far: an
/// absolute one as 0-based, a relative one as [`REL`]; `need` raised to
/// the elements the text before the chunk must define for it. Any error
/// (the one-pass reading names it).
pub(super) fn chunk_index(
    tok: &str,
    count: usize,
    need: &mut i64,
    relative: &mut bool,
) -> Result<u32, ObjError> {
    // Which error does not matter: the one-pass reading finds it again.
    let bad = || ObjError::NoFaces;
    let i: i64 = tok.parse().map_err(|_| bad())?;
    let count = count as i64;
    if i > 0 {
        let idx = i - 1;
        if idx >= i64::from(REL) {
            return Err(bad());
        }
        *need = (*need).max(idx + 1 - count);
        Ok(idx as u32)
    } else if i < 0 {
        let offset = count + i;
        if !(-BIAS..BIAS - 1).contains(&offset) {
            return Err(bad());
        }
        *need = (*need).max(-offset);
        *relative = true;
        Ok(REL | (offset + BIAS) as u32)
    } else {
        Err(bad())
    }
}

/// The chunks put together in order, as the one pass would have read the
/// whole; `None` when an index is out of range.
fn merge(chunks: Vec<Prepared>, stem: &str) -> Option<Prepared> {
    let (mut p, mut state) = start_state(stem);
    let total = |f: fn(&Prepared) -> usize| chunks.iter().map(f).sum::<usize>();
    let n_v = total(|c| c.data.positions.len());
    if n_v
        .max(total(|c| c.data.texcoords.len()))
        .max(total(|c| c.data.normals.len()))
        >= REL as usize
    {
        return None;
    }
    p.data.positions.reserve_exact(n_v);
    p.data
        .texcoords
        .reserve_exact(total(|c| c.data.texcoords.len()));
    p.data
        .normals
        .reserve_exact(total(|c| c.data.normals.len()));
    let all_colored = total(|c| c.colored) == n_v;
    for mut c in chunks {
        let base = [
            p.data.positions.len(),
            p.data.texcoords.len(),
            p.data.normals.len(),
        ];
        if (0..3).any(|k| c.need[k] > base[k] as i64) {
            return None;
        }
        if c.relative {
            let fix = |i: &mut u32, base: usize| {
                if *i != ABSENT && *i & REL != 0 {
                    *i = (base as i64 + i64::from(*i & !REL) - BIAS) as u32;
                }
            };
            for corner in &mut c.corners {
                fix(&mut corner.v, base[0]);
                fix(&mut corner.vt, base[1]);
                fix(&mut corner.vn, base[2]);
            }
        }
        // The statements, applied in order: a face's section was the
        // number of statements before it in the chunk.
        let mut section_of = vec![p.sections.len() - 1];
        for event in c.events.take().unwrap_or_default() {
            p.statement(event, stem, &mut state);
            section_of.push(p.sections.len() - 1);
        }
        for f in &mut c.faces {
            f.section = section_of[f.section];
        }
        p.data.positions.append(&mut c.data.positions);
        p.data.texcoords.append(&mut c.data.texcoords);
        p.data.normals.append(&mut c.data.normals);
        if all_colored {
            p.data.colors.append(&mut c.data.colors);
        }
        p.libraries.append(&mut c.libraries);
        p.colored += c.colored;
        p.skipped_elements += c.skipped_elements;
        p.short_faces += c.short_faces;
        p.freeform += c.freeform;
        p.odd_vertex_lines += c.odd_vertex_lines;
        c.end_part();
        p.parts.append(&mut c.parts);
    }
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Everything the parse gives, in a form to compare (the colours when
    /// every vertex has one: the reader drops them else).
    fn summary(p: &Prepared) -> String {
        let colors = if p.colored == p.data.positions.len() {
            &p.data.colors[..]
        } else {
            &[]
        };
        let faces: Vec<(usize, Vec<Corner>)> = p
            .parts
            .iter()
            .flat_map(|part| {
                part.faces
                    .iter()
                    .map(|f| (f.section, part.corners[f.start..f.start + f.len].to_vec()))
            })
            .collect();
        format!(
            "{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}",
            p.data.positions,
            p.data.texcoords,
            p.data.normals,
            colors,
            p.libraries,
            p.objects,
            p.sections,
            faces,
            [
                p.colored,
                p.skipped_elements,
                p.short_faces,
                p.freeform,
                p.odd_vertex_lines
            ]
        )
    }

    const TEXT: &str = "# a comment\r\nmtllib a.mtl\nv 0 0 0\nv 1 0 0 # x\nv 1 1 0\n\
        v 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\ng first\nusemtl red\n\
        f 1/1/1 2/2/1 3/3/1\nf -4/-3/-1 -3/-2/-1 \\\n -2/-1/-1 -1/-1/-1\n\
        l 1 2\no second\nv 2 2 2 1 0 0\nv 3 2 2\nv 3 3 2 2\nf -3 -2 -1\n\
        g\nusemtl\nf 1 2\nf 5 -2 7  # comment\ng first\nusemtl red\n\
        g first\nf 1 2 3 4\nmtllib b.mtl\ncurv 0 1\nv 1 2 3 4 5\n\
        f -1 -2 -3 \\\n\\\n\nf 1/1 2/2 3/3\n";

    #[test]
    fn chunks_give_the_one_pass_result() {
        let one = preprocess(TEXT, "stem").unwrap();
        assert_eq!(one.objects, ["stem", "second"]);
        assert!(one.sections.len() > 4);
        let expected = summary(&one);
        for size in [1, 2, 3, 5, 7, 16, 40, 100, TEXT.len(), 1 << 20] {
            let chunks = split(TEXT.as_bytes(), size);
            assert_eq!(chunks.concat(), TEXT.as_bytes());
            if size < 4 {
                // Every line its own chunk, but for the continued ones.
                assert!(chunks.len() > 30, "{size}: {}", chunks.len());
            }
            let p = prepare(TEXT.as_bytes(), "stem", size).unwrap();
            assert_eq!(summary(&p), expected, "chunks of {size} bytes");
        }
    }

    #[test]
    fn colours_in_chunks() {
        let text = "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n";
        let one = summary(&preprocess(text, "s").unwrap());
        assert!(one.contains("[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]"));
        assert_eq!(summary(&prepare(text.as_bytes(), "s", 3).unwrap()), one);
    }

    #[test]
    fn errors_are_the_one_pass_errors() {
        for bad in [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 -4\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\nv 1 1 1\n",
            "v 0 0 0\nv 1 0 0\nf 1 2 3 \\\n 1\nv 0 1 0\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nvt x\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1/0 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 99999999999\n",
        ] {
            let one = preprocess(bad, "s").err().expect("an error").to_string();
            for size in [1, 4, 1 << 20] {
                let e = prepare(bad.as_bytes(), "s", size).err().expect("an error");
                assert_eq!(e.to_string(), one, "{bad:?} in chunks of {size}");
            }
        }
        // Bytes that are not UTF-8 read as U+FFFD, in chunks too.
        let latin = b"# caf\xe9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let one = summary(&preprocess(&String::from_utf8_lossy(latin), "s").unwrap());
        assert_eq!(summary(&prepare(latin, "s", 2).unwrap()), one);
    }
}
