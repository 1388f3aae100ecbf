//! Hostile asset folders for the real `crackle` binary: each case is a
//! folder built from one seed (`case/asset`, `case/out`, `case/victim`,
//! `case/cfg`, `case/cwd`) holding the fixtures plus what one or a few
//! [`Class`]es plant (links into the victim folder, planted temporaries and
//! side-file names, links a copy rule would follow, sparse buffers, image
//! bombs, thousands of objects or primitives), and the command line
//! (`crack`, `convert` or `batch` with `unmatched = "copy"`) run on it.
//! `hostile_run` runs it and checks what happened.

use super::Rng;
use std::ffi::OsString;
use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};

/// What a case plants; a case has one main class (the seed's low byte,
/// so a run of N cases goes round every class) and up to two more.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Class {
    /// A folder link inside the output folder (where an output goes)
    /// pointing at the victim folder, or at a missing folder inside it.
    OutDirLink,
    /// The output path itself a link to a victim file (or a missing one).
    OutputLink,
    /// Links to victim files and the victim folder under temporary-like
    /// names (`.NAME.crackle-tmp-PID-N`) beside every output.
    PlantedTemp,
    /// Links under content-tagged side-file names (`stem.<16 hex>.bin`,
    /// the input image's own tag) and an old `.gltf` naming them and
    /// files in the victim folder.
    PlantedSide,
    /// `batch` with `unmatched = "copy"` over assets whose buffer, image,
    /// MTL or sub-folder link to the victim or to `/proc/self/environ`.
    CopyLinks,
    /// While the child runs, a thread swaps a buffer, an image (or, in a
    /// batch, the asset itself) for a link to a victim file and back.
    Swapped,
    /// An external buffer declaring a huge byteLength, the file sparse
    /// (of that length, or of another).
    Sparse,
    /// A tiny PNG declaring a huge size, as a texture the bake draws over
    /// and as a mask (pipeline file, `--set`, material mask).
    ImageBomb,
    /// An OBJ of thousands of one-triangle `o` objects.
    ManyObjects,
    /// A glTF of thousands of primitives over one buffer.
    ManyPrimitives,
}

pub const CLASSES: [Class; 10] = [
    Class::OutDirLink,
    Class::OutputLink,
    Class::PlantedTemp,
    Class::PlantedSide,
    Class::CopyLinks,
    Class::Swapped,
    Class::Sparse,
    Class::ImageBomb,
    Class::ManyObjects,
    Class::ManyPrimitives,
];

impl Class {
    /// The class a case seed names as its main one.
    pub fn of_seed(seed: u64) -> Class {
        CLASSES[(seed & 0xff) as usize % CLASSES.len()]
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Cmd {
    Crack,
    Convert,
    Batch,
}

/// What every case shares.
#[derive(Clone, Debug)]
pub struct Settings {
    /// The `crackle` binary.
    pub bin: PathBuf,
    /// The project's `fixtures/`.
    pub fixtures: PathBuf,
    /// `--max-memory` given to every run.
    pub max_memory: u64,
    /// The child's peak resident memory may be `max_memory + slack`.
    pub slack: u64,
    /// A run longer than this is killed and reported as a hang.
    pub limit: std::time::Duration,
    /// Most objects or primitives of the many-objects classes.
    pub max_many: usize,
}

/// One built case.
#[derive(Debug)]
pub struct Case {
    pub seed: u64,
    pub classes: Vec<Class>,
    pub cmd: Cmd,
    /// The case folder.
    pub dir: PathBuf,
    /// The arguments after the binary.
    pub args: Vec<OsString>,
    /// The secret: in every victim file and in the child's environment
    /// (`CRACKLE_FUZZ_SECRET`); no output may hold it.
    pub token: String,
    /// (path in the asset folder, victim file): swapped while it runs.
    pub swaps: Vec<(PathBuf, PathBuf)>,
}

impl Case {
    pub fn asset(&self) -> PathBuf {
        self.dir.join("asset")
    }
    pub fn out(&self) -> PathBuf {
        self.dir.join("out")
    }
    pub fn victim(&self) -> PathBuf {
        self.dir.join("victim")
    }
    /// The command line, quoted for a shell.
    pub fn command_line(&self, bin: &Path) -> String {
        let q = |s: &std::ffi::OsStr| format!("'{}'", s.to_string_lossy().replace('\'', "'\\''"));
        let mut s = format!(
            "cd {} && CRACKLE_FUZZ_SECRET={} {}",
            q(self.dir.join("cwd").as_os_str()),
            self.token,
            q(bin.as_os_str())
        );
        for a in &self.args {
            s.push(' ');
            s.push_str(&q(a));
        }
        s
    }
}

/// A PNG (valid chunks and CRCs) whose header declares `w` x `h` RGBA
/// pixels, with a few bytes of image data.
pub fn png_bomb(w: u32, h: u32) -> Vec<u8> {
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        let crc = crc32(&out[start..]);
        out.extend_from_slice(&crc.to_be_bytes());
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    // A zlib stream of a few zero rows, cut short.
    chunk(
        &mut out,
        b"IDAT",
        &[0x78, 0x9c, 0x63, 0x60, 0x18, 0x05, 0x00],
    );
    chunk(&mut out, b"IEND", &[]);
    out
}

fn crc32(b: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &x in b {
        c ^= u32::from(x);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// The content tag crackle names side files with (first 8 bytes of the
/// SHA-256, hex).
pub fn content_tag(bytes: &[u8]) -> String {
    use sha2::Digest as _;
    sha2::Sha256::digest(bytes)[..8]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// `len` bytes of the token repeated (a same-sized stand-in for a file).
fn token_bytes(token: &str, len: usize) -> Vec<u8> {
    token.bytes().cycle().take(len.max(token.len())).collect()
}

/// An OBJ of `n` one-triangle objects in a grid, with the cube's MTL.
pub fn many_objects_obj(n: usize) -> String {
    let mut s = String::from("mtllib cube.mtl\n");
    let side = (n as f64).sqrt().ceil() as usize;
    for i in 0..n {
        let (x, z) = ((i % side) as f64, (i / side) as f64);
        s.push_str(&format!(
            "o piece_{i}\nusemtl {}\nv {x} 0 {z}\nv {} 0 {z}\nv {x} 0.5 {}\nvt 0 0\nvt 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\n",
            if i % 2 == 0 { "red" } else { "textured" },
            x + 0.9,
            z + 0.9
        ));
    }
    s
}

/// A glTF of one mesh with `n` primitives over one buffer: each primitive
/// its own triangle (its own accessor), or all of them one accessor.
/// Returns (JSON, buffer bytes); the buffer is `bin_uri` or, when `None`,
/// a data URI.
pub fn many_primitives_gltf(n: usize, shared: bool, bin_uri: Option<&str>) -> (String, Vec<u8>) {
    let mut bin = Vec::with_capacity(n * 36);
    for i in 0..n {
        let (x, z) = ((i % 100) as f32, (i / 100) as f32);
        for p in [[x, 0.0, z], [x + 0.9, 0.0, z], [x, 0.5, z + 0.9]] {
            for c in p {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    let count = if shared { 1 } else { n };
    let accessors: Vec<String> = (0..count)
        .map(|i| {
            let (x, z) = ((i % 100) as f32, (i / 100) as f32);
            format!(
                "{{\"bufferView\":0,\"byteOffset\":{},\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[{x},0,{z}],\"max\":[{},0.5,{}]}}",
                i * 36,
                x + 0.9,
                z + 0.9
            )
        })
        .collect();
    let prims: Vec<String> = (0..n)
        .map(|i| {
            format!(
                "{{\"attributes\":{{\"POSITION\":{}}}}}",
                if shared { 0 } else { i }
            )
        })
        .collect();
    let uri = match bin_uri {
        Some(u) => u.to_string(),
        None => {
            use base64::Engine as _;
            format!(
                "data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(&bin)
            )
        }
    };
    let json = format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scene\":0,\"scenes\":[{{\"nodes\":[0]}}],\"nodes\":[{{\"mesh\":0}}],\
         \"meshes\":[{{\"primitives\":[{}]}}],\"buffers\":[{{\"byteLength\":{},\"uri\":\"{uri}\"}}],\
         \"bufferViews\":[{{\"buffer\":0,\"byteLength\":{}}}],\"accessors\":[{}]}}",
        prims.join(","),
        bin.len(),
        bin.len(),
        accessors.join(",")
    );
    (json, bin)
}

/// Builds a case's folder; `dir` must not exist yet.
struct Builder<'a> {
    s: &'a Settings,
    rng: Rng,
    dir: PathBuf,
    token: String,
    /// Folder of the assets below `asset/` ("" or "sub").
    sub: &'static str,
    /// Input files for crack/convert, the first the one run (relative to
    /// `asset/`).
    inputs: Vec<String>,
    swaps: Vec<(PathBuf, PathBuf)>,
    /// Extra arguments (pipeline, --set).
    extra: Vec<OsString>,
    /// Rules file lines after `unmatched = "copy"`.
    rules: Vec<String>,
    victim_n: usize,
}

fn write(p: &Path, bytes: impl AsRef<[u8]>) {
    if let Some(d) = p.parent() {
        std::fs::create_dir_all(d).unwrap();
    }
    std::fs::write(p, bytes).unwrap();
}

impl Builder<'_> {
    fn asset_dir(&self) -> PathBuf {
        self.dir.join("asset").join(self.sub)
    }
    fn victim(&self) -> PathBuf {
        self.dir.join("victim")
    }
    fn fixture(&self, name: &str) -> Vec<u8> {
        std::fs::read(self.s.fixtures.join(name)).unwrap()
    }
    /// A new victim file of `len` token bytes (or `bytes` then the token).
    fn victim_file(&mut self, name: &str, bytes: Option<&[u8]>, len: usize) -> PathBuf {
        self.victim_n += 1;
        let p = self.victim().join(format!("{}-{name}", self.victim_n));
        let body = match bytes {
            Some(b) => {
                let mut v = b.to_vec();
                v.extend_from_slice(self.token.as_bytes());
                v
            }
            None => token_bytes(&self.token, len),
        };
        write(&p, body);
        p
    }
    /// A symbolic link at `at` to `to` (parents made).
    fn link(&self, to: &Path, at: &Path) {
        if let Some(d) = at.parent() {
            std::fs::create_dir_all(d).unwrap();
        }
        let _ = std::fs::remove_file(at);
        symlink(to, at).unwrap();
    }

    /// Make `dir` (below `out/`) unless a folder link lies on its way
    /// (the planted files go into the output folder, never through a link
    /// into the victim); whether it is there.
    fn out_dir(&self, dir: &Path) -> bool {
        let out = self.dir.join("out");
        let Ok(rel) = dir.strip_prefix(&out) else {
            return false;
        };
        let mut at = out;
        for c in rel.components() {
            at.push(c);
            if std::fs::symlink_metadata(&at).is_ok_and(|m| m.file_type().is_symlink()) {
                return false;
            }
        }
        std::fs::create_dir_all(dir).is_ok()
    }

    /// The base asset: the textured quad, the cube or the hierarchy GLB.
    fn base(&mut self) {
        let d = self.asset_dir();
        match self.rng.below(3) {
            0 => {
                for f in ["textured_quad.gltf", "textured_quad.bin", "checker.png"] {
                    write(&d.join(f), self.fixture(f));
                }
                self.inputs.push("textured_quad.gltf".into());
            }
            1 => {
                for f in ["cube.obj", "cube.mtl", "cube texture.png"] {
                    write(&d.join(f), self.fixture(f));
                }
                self.inputs.push("cube.obj".into());
            }
            _ => {
                write(&d.join("hierarchy.glb"), self.fixture("hierarchy.glb"));
                self.inputs.push("hierarchy.glb".into());
            }
        }
    }

    fn sparse(&mut self) {
        let d = self.asset_dir();
        let declared: u64 = [300 << 20, (1 << 30) + 4096, 5 << 30, 140][self.rng.below(4)];
        let real: u64 = match self.rng.below(3) {
            0 => declared,
            1 => 140,
            _ => [(1u64 << 30) + 12, 5 << 30][self.rng.below(2)],
        };
        let json = String::from_utf8(self.fixture("textured_quad.gltf"))
            .unwrap()
            .replace("\"textured_quad.bin\"", "\"sparse.bin\"")
            .replace(
                "\"byteLength\": 140",
                &format!("\"byteLength\": {declared}"),
            );
        write(&d.join("sparse.gltf"), json);
        write(&d.join("sparse.bin"), self.fixture("textured_quad.bin"));
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(d.join("sparse.bin"))
            .unwrap();
        f.set_len(real.max(140)).unwrap();
        write(&d.join("checker.png"), self.fixture("checker.png"));
        self.inputs.insert(0, "sparse.gltf".into());
    }

    fn image_bomb(&mut self) {
        let (w, h) = [
            (16384, 16384),
            (65535, 65535),
            (16385, 1),
            (8192, 8192),
            (1, 100_000_000),
        ][self.rng.below(5)];
        let bomb = png_bomb(w, h);
        let d = self.asset_dir();
        // As the texture the bake draws over.
        if self.rng.below(2) == 0 {
            for f in ["textured_quad.gltf", "textured_quad.bin"] {
                write(&d.join(f), self.fixture(f));
            }
            write(&d.join("checker.png"), &bomb);
            self.inputs.insert(0, "textured_quad.gltf".into());
        } else {
            for f in ["cube.obj", "cube.mtl"] {
                write(&d.join(f), self.fixture(f));
            }
            write(&d.join("cube texture.png"), &bomb);
            self.inputs.insert(0, "cube.obj".into());
        }
        // And as a mask: a pipeline file, --set on a preset, or the
        // material's own texture.
        let cfg = self.dir.join("cfg");
        write(&cfg.join("bomb.png"), &bomb);
        let cheap = "[simulation]\ncell_size_relative = 0.2\nmax_rounds = 3\n\n";
        let mask = match self.rng.below(4) {
            0 => "mask = { image = \"bomb.png\" }",
            1 => "mask = { material = \"checker\" }",
            2 => "mask = { material = \"textured\" }",
            _ => "",
        };
        match (mask, self.rng.below(3)) {
            ("", _) | (_, 0) => {
                // The bake over the texture.
                self.extra.extend(["--preset".into(), "glaze".into()]);
                self.rules
                    .push("[[rule]]\nglob = \"**\"\npreset = \"glaze\"\n".into());
            }
            (_, 1) => {
                write(
                    &cfg.join("mask.toml"),
                    format!("{cheap}[[stress]]\nkind = \"uniform\"\nevolve = 0.05\n{mask}\n\n[post]\nbake = true\n"),
                );
                self.extra
                    .extend(["--pipeline".into(), cfg.join("mask.toml").into()]);
                self.rules
                    .push("[[rule]]\nglob = \"**\"\npipeline = \"mask.toml\"\n".into());
            }
            _ => {
                self.extra.extend([
                    "--preset".into(),
                    "texture-mask".into(),
                    "--set".into(),
                    format!("stress.0.mask.image={}", cfg.join("bomb.png").display()).into(),
                ]);
                self.rules
                    .push("[[rule]]\nglob = \"**\"\npreset = \"texture-mask\"\n".into());
            }
        }
    }

    fn many_objects(&mut self) {
        let n = self.s.max_many / 2 + self.rng.below(self.s.max_many / 2 + 1);
        let d = self.asset_dir();
        write(&d.join("many.obj"), many_objects_obj(n));
        for f in ["cube.mtl", "cube texture.png"] {
            write(&d.join(f), self.fixture(f));
        }
        self.inputs.insert(0, "many.obj".into());
    }

    fn many_primitives(&mut self) {
        let n = self.s.max_many / 2 + self.rng.below(self.s.max_many / 2 + 1);
        let shared = self.rng.below(3) == 0;
        let external = self.rng.below(2) == 0;
        let (json, bin) = many_primitives_gltf(n, shared, external.then_some("prims.bin"));
        let d = self.asset_dir();
        write(&d.join("prims.gltf"), json);
        if external {
            write(&d.join("prims.bin"), bin);
        }
        self.inputs.insert(0, "prims.gltf".into());
    }

    /// Assets whose references a copy rule would follow out of the folder.
    fn copy_links(&mut self) {
        let root = self.dir.join("asset");
        // The quad: its buffer a link to a same-sized victim file, its
        // image one to the child's environment (or a victim PNG).
        let q = root.join("links");
        write(
            &q.join("textured_quad.gltf"),
            self.fixture("textured_quad.gltf"),
        );
        let bin = self.victim_file("textured_quad.bin", None, 140);
        self.link(&bin, &q.join("textured_quad.bin"));
        let png = if self.rng.below(2) == 0 {
            PathBuf::from("/proc/self/environ")
        } else {
            let b = self.fixture("checker.png");
            self.victim_file("checker.png", Some(&b), 0)
        };
        self.link(&png, &q.join("checker.png"));
        // The cube: the MTL and the texture links to victim files.
        let c = root.join("links2");
        write(&c.join("cube.obj"), self.fixture("cube.obj"));
        let mtl = self.fixture("cube.mtl");
        let mtl = self.victim_file("cube.mtl", Some(&mtl), 0);
        self.link(&mtl, &c.join("cube.mtl"));
        let tex = self.fixture("cube texture.png");
        let tex = self.victim_file("cube texture.png", Some(&tex), 0);
        self.link(&tex, &c.join("cube texture.png"));
        // A glTF whose image lies in a folder that links to the victim.
        let f = root.join("links3");
        let gltf = String::from_utf8(self.fixture("textured_quad.gltf"))
            .unwrap()
            .replace("\"checker.png\"", "\"tex/checker.png\"");
        write(&f.join("quad.gltf"), gltf);
        write(
            &f.join("textured_quad.bin"),
            self.fixture("textured_quad.bin"),
        );
        let b = self.fixture("checker.png");
        let sub = self.victim().join("texdir");
        write(
            &sub.join("checker.png"),
            [b.as_slice(), self.token.as_bytes()].concat(),
        );
        self.link(&sub, &f.join("tex"));
        // An asset that is itself a link to the victim.
        let g = self.fixture("hierarchy.glb");
        let glb = self.victim_file("hierarchy.glb", Some(&g), 0);
        self.link(&glb, &root.join("links4/linked.glb"));
    }

    /// Swap the main input's side files (in a batch, the input too).
    fn swapped(&mut self, batch: bool) {
        let d = self.asset_dir();
        let main = self.inputs[0].clone();
        let mut names: Vec<String> = match main.as_str() {
            "textured_quad.gltf" | "sparse.gltf" => {
                vec!["textured_quad.bin".into(), "checker.png".into()]
            }
            "cube.obj" | "many.obj" => vec!["cube texture.png".into(), "cube.mtl".into()],
            "prims.gltf" => vec!["prims.bin".into()],
            _ => vec![],
        };
        names.retain(|n| d.join(n).is_file());
        if names.is_empty() && !batch {
            // The input the user names may be a link (crack and convert
            // follow it): swap the quad's side files instead.
            for f in ["textured_quad.gltf", "textured_quad.bin", "checker.png"] {
                write(&d.join(f), self.fixture(f));
            }
            self.inputs.insert(0, "textured_quad.gltf".into());
            names = vec!["textured_quad.bin".into(), "checker.png".into()];
        }
        if batch {
            names.push(main.clone());
        }
        for n in names {
            let orig = std::fs::read(d.join(&n)).unwrap();
            // A buffer: the same length of token bytes (it passes the
            // length checks); anything else: its own bytes then the token.
            let v = if n.ends_with(".bin") {
                self.victim_file(&n, None, orig.len())
            } else {
                self.victim_file(&n, Some(&orig), 0)
            };
            self.swaps.push((d.join(&n), v));
        }
    }

    /// The outputs the command writes (paths below `out/`).
    fn outputs(&self, cmd: Cmd, ext: &str) -> Vec<PathBuf> {
        let out = self.dir.join("out");
        let stem = |f: &str| {
            Path::new(f)
                .file_stem()
                .unwrap()
                .to_string_lossy()
                .into_owned()
        };
        match cmd {
            Cmd::Batch => self
                .inputs
                .iter()
                .map(|f| out.join(self.sub).join(format!("{}.{ext}", stem(f))))
                .collect(),
            _ => vec![out.join(format!("{}.{ext}", stem(&self.inputs[0])))],
        }
    }

    fn out_dir_link(&mut self, cmd: Cmd) {
        let out = self.dir.join("out");
        let to = if self.rng.below(2) == 0 {
            self.victim()
        } else {
            self.victim().join("made")
        };
        if cmd == Cmd::Batch {
            self.sub = "sub";
        }
        self.link(&to, &out.join("sub"));
    }

    fn output_link(&mut self, outputs: &[PathBuf]) {
        for o in outputs {
            let name = o.file_name().unwrap().to_string_lossy().into_owned();
            let to = if self.rng.below(2) == 0 {
                let g = self.fixture("hierarchy.glb");
                self.victim_file(&name, Some(&g), 0)
            } else {
                self.victim().join(format!("missing-{name}"))
            };
            if self.out_dir(o.parent().unwrap()) && std::fs::symlink_metadata(o).is_err() {
                symlink(&to, o).unwrap();
            }
        }
    }

    fn planted_temp(&mut self, outputs: &[PathBuf]) {
        let me = std::process::id();
        let secret = self.victim_file("planted", None, 64);
        let victim = self.victim();
        for o in outputs {
            let dir = o.parent().unwrap().to_path_buf();
            if !self.out_dir(&dir) {
                continue;
            }
            let name = o.file_name().unwrap().to_string_lossy().into_owned();
            let mut names = vec![name.clone()];
            if dir.ends_with("out") || dir.ends_with("sub") {
                names.push(".crackle-batch.json".into());
            }
            for n in names {
                for pid in (me + 1..me + 400).chain([1, u32::MAX]) {
                    for k in 0..2 {
                        let at = dir.join(format!(".{n}.crackle-tmp-{pid}-{k}"));
                        if std::fs::symlink_metadata(&at).is_err() {
                            let to = if k == 0 { &secret } else { &victim };
                            let _ = symlink(to, &at);
                        }
                    }
                }
                // A stale regular temporary of a dead process (tidied).
                let _ = std::fs::write(dir.join(format!(".{n}.crackle-tmp-1-7")), b"stale");
            }
        }
    }

    fn planted_side(&mut self, outputs: &[PathBuf]) {
        let mut images = Vec::new();
        for f in ["checker.png", "cube texture.png"] {
            let b = self.fixture(f);
            images.push(crate_tagged(f, &content_tag(&b)));
        }
        for o in outputs {
            let dir = o.parent().unwrap().to_path_buf();
            if !self.out_dir(&dir) {
                continue;
            }
            let stem = o.file_stem().unwrap().to_string_lossy().into_owned();
            let mut names = images.clone();
            for _ in 0..3 {
                names.push(format!("{stem}.{:016x}.bin", self.rng.next()));
            }
            for n in &names {
                let v = self.victim_file(n, None, 64);
                if std::fs::symlink_metadata(dir.join(n)).is_err() {
                    let _ = symlink(&v, dir.join(n));
                }
            }
            // An old .gltf (where the output goes) naming those, a file in
            // the victim folder and one behind a folder link.
            let gl = o.with_extension("gltf");
            if std::fs::symlink_metadata(&gl).is_err() {
                let far = format!("far.{:016x}.bin", self.rng.next());
                write(&self.victim().join(&far), token_bytes(&self.token, 64));
                let uris = [
                    names[names.len() - 1].clone(),
                    names[0].clone(),
                    format!("../victim/{far}"),
                    format!("%2E%2E/victim/{far}"),
                    format!("{}/victim/{far}", self.dir.display()),
                ];
                let buffers: Vec<String> = uris
                    .iter()
                    .map(|u| format!("{{\"byteLength\":64,\"uri\":\"{u}\"}}"))
                    .collect();
                write(
                    &gl,
                    format!(
                        "{{\"asset\":{{\"version\":\"2.0\"}},\"buffers\":[{}]}}",
                        buffers.join(",")
                    ),
                );
            }
        }
    }
}

/// `name` with `.tag` before its extension (crackle's side-file names).
fn crate_tagged(name: &str, tag: &str) -> String {
    match name.rfind('.') {
        Some(i) if i > 0 => format!("{}.{tag}{}", &name[..i], &name[i..]),
        _ => format!("{name}.{tag}"),
    }
}

/// Build case `seed` in `dir` (which must not exist).
pub fn build(s: &Settings, seed: u64, dir: &Path) -> Case {
    let mut rng = Rng(seed ^ 0x5851_f42d_4c95_7f2d);
    let main = Class::of_seed(seed);
    let mut classes = vec![main];
    for _ in 0..rng.below(3) {
        let c = CLASSES[rng.below(CLASSES.len())];
        if !classes.contains(&c) {
            classes.push(c);
        }
    }
    classes.sort();
    let has = |c: Class| classes.contains(&c);
    let cmd = if has(Class::CopyLinks) {
        Cmd::Batch
    } else {
        [Cmd::Crack, Cmd::Convert, Cmd::Batch][rng.below(3)]
    };
    let token = format!("CRACKLEFUZZ{:016x}{:08x}", rng.next(), rng.next() as u32);
    for sub in ["asset", "out", "victim", "cfg", "cwd"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    let mut b = Builder {
        s,
        rng,
        dir: dir.to_path_buf(),
        token: token.clone(),
        sub: "",
        inputs: Vec::new(),
        swaps: Vec::new(),
        extra: Vec::new(),
        rules: Vec::new(),
        victim_n: 0,
    };
    // Sentinels the victim holds from the start.
    write(&b.victim().join("secret.txt"), token_bytes(&token, 256));
    if b.rng.below(2) == 0 {
        b.sub = "sub";
    }
    if has(Class::OutDirLink) {
        b.out_dir_link(cmd);
    }
    if cmd == Cmd::Batch || b.rng.below(2) == 0 || classes.len() == 1 {
        b.base();
    }
    if has(Class::Sparse) {
        b.sparse();
    }
    if has(Class::ImageBomb) {
        b.image_bomb();
    }
    if has(Class::ManyObjects) {
        b.many_objects();
    }
    if has(Class::ManyPrimitives) {
        b.many_primitives();
    }
    if b.inputs.is_empty() {
        b.base();
    }
    if has(Class::Swapped) {
        b.swapped(cmd == Cmd::Batch);
    }
    if has(Class::CopyLinks) {
        b.copy_links();
    }
    let gltf_out = b.rng.below(2) == 0;
    let ext = if gltf_out { "gltf" } else { "glb" };
    let outputs = b.outputs(cmd, ext);
    if cmd == Cmd::Batch && !has(Class::OutDirLink) && b.rng.below(2) == 0 {
        // The output folder tree exists already (from an earlier run).
        for o in &outputs {
            b.out_dir(o.parent().unwrap());
        }
    }
    if has(Class::PlantedSide) {
        b.planted_side(&outputs);
    }
    if has(Class::OutputLink) {
        b.output_link(&outputs);
    }
    if has(Class::PlantedTemp) {
        b.planted_temp(&outputs);
    }
    let args = b.args(cmd, gltf_out, &outputs);
    Case {
        seed,
        classes,
        cmd,
        dir: dir.to_path_buf(),
        args,
        token,
        swaps: b.swaps,
    }
}

impl Builder<'_> {
    /// The command line: cheap simulation settings, `--max-memory`.
    fn args(&mut self, cmd: Cmd, gltf_out: bool, outputs: &[PathBuf]) -> Vec<OsString> {
        let mut a: Vec<OsString> = Vec::new();
        let cheap = |a: &mut Vec<OsString>| {
            for x in ["--max-triangles", "1500", "--max-rounds", "3"] {
                a.push(x.into());
            }
        };
        match cmd {
            Cmd::Convert => {
                a.push("convert".into());
                a.push(self.asset_dir().join(&self.inputs[0]).into());
                a.push(outputs[0].clone().into());
            }
            Cmd::Crack => {
                a.push("crack".into());
                a.push(self.asset_dir().join(&self.inputs[0]).into());
                a.push(outputs[0].clone().into());
                if self.extra.is_empty() {
                    let preset = ["glaze", "mud", "texture-mask"][self.rng.below(3)];
                    a.extend(["--preset".into(), preset.into()]);
                } else {
                    a.append(&mut self.extra);
                }
                cheap(&mut a);
            }
            Cmd::Batch => {
                let cfg = self.dir.join("cfg");
                let mut rules = String::from("unmatched = \"copy\"\n\n");
                if self.rules.is_empty() && self.rng.below(2) == 0 {
                    // Crack the OBJ files; copy the rest.
                    rules.push_str("[[rule]]\nglob = \"*.obj\"\npreset = \"mud\"\n");
                }
                for r in &self.rules {
                    rules.push_str(r);
                }
                write(&cfg.join("rules.toml"), rules);
                a.push("batch".into());
                a.push(self.dir.join("asset").into());
                a.extend(["-r".into(), "--out".into(), self.dir.join("out").into()]);
                a.extend(["--rules".into(), cfg.join("rules.toml").into()]);
                a.extend(["-j".into(), "2".into()]);
                if gltf_out {
                    a.extend(["--format".into(), "gltf".into()]);
                }
                cheap(&mut a);
            }
        }
        a.push("-q".into());
        a.push("--max-memory".into());
        a.push(format!("{}", self.s.max_memory).into());
        a
    }
}
