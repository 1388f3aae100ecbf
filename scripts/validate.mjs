#!/usr/bin/env node
// Validate glTF 2.0 files with the Khronos glTF-Validator (npm `gltf-validator`,
// installed into tools/node_modules by scripts/install-validator.sh).
//
// Usage: node scripts/validate.mjs <file.gltf|file.glb> [...]
//
// Prints ONE JSON line per file to stdout:
//   {"file":..., "errors":N, "warnings":N, "infos":N, "hints":N,
//    "messages":[{"code":..., "message":..., "severity":S, "pointer":...}, ...]}
// severity: 0 = error, 1 = warning, 2 = info, 3 = hint.
// External resources (.bin, images) are resolved relative to the file's folder.
//
// Exit codes: 0 = every file was validated (whatever the findings),
//             1 = a file could not be read or the validator refused it outright
//                 (a JSON line with a VALIDATOR_FAILED error is still printed),
//             2 = usage error, or the validator package is not installed.
import { createRequire } from "node:module";
import { readFile } from "node:fs/promises";
import path from "node:path";
import { fileURLToPath } from "node:url";

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.resolve(here, "..");
const usage = "usage: node scripts/validate.mjs <file.gltf|file.glb> [...]";

const args = process.argv.slice(2);
if (args.length === 0 || args.includes("-h") || args.includes("--help")) {
  console.error(usage);
  process.exit(2);
}
const unknownFlag = args.find((a) => a.startsWith("-"));
if (unknownFlag) {
  console.error(`validate.mjs: unknown option ${unknownFlag}\n${usage}`);
  process.exit(2);
}

let validator;
try {
  const require = createRequire(path.join(root, "tools", "package.json"));
  validator = require("gltf-validator");
} catch (e) {
  console.error(
    "validate.mjs: cannot load gltf-validator from tools/node_modules; " +
      "run `bash scripts/install-validator.sh` first\n" + String(e),
  );
  process.exit(2);
}

function failure(file, text) {
  return {
    file,
    errors: 1,
    warnings: 0,
    infos: 0,
    hints: 0,
    messages: [{ code: "VALIDATOR_FAILED", message: text, severity: 0, pointer: "" }],
  };
}

async function validateOne(file) {
  const full = path.resolve(file);
  const dir = path.dirname(full);
  let bytes;
  try {
    bytes = new Uint8Array(await readFile(full));
  } catch (e) {
    return [failure(file, `cannot read file: ${e.message}`), false];
  }
  const ext = path.extname(full).toLowerCase();
  const options = {
    uri: path.basename(full),
    maxIssues: 0, // unlimited: the counts must be exact
    writeTimestamp: false,
    externalResourceFunction: (uri) =>
      readFile(path.resolve(dir, decodeURIComponent(uri))).then(
        (data) => new Uint8Array(data),
        (err) => Promise.reject(String(err.message || err)),
      ),
  };
  if (ext === ".glb") options.format = "glb";
  else if (ext === ".gltf") options.format = "gltf";
  let report;
  try {
    report = await validator.validateBytes(bytes, options);
  } catch (e) {
    return [failure(file, `validator refused the file: ${String(e)}`), false];
  }
  const issues = report.issues || {};
  const messages = (issues.messages || []).map((m) => ({
    code: String(m.code ?? ""),
    message: String(m.message ?? ""),
    severity: Number(m.severity ?? 0),
    pointer: String(m.pointer ?? (m.offset !== undefined ? `@${m.offset}` : "")),
  }));
  return [
    {
      file,
      errors: issues.numErrors ?? 0,
      warnings: issues.numWarnings ?? 0,
      infos: issues.numInfos ?? 0,
      hints: issues.numHints ?? 0,
      messages,
    },
    true,
  ];
}

let code = 0;
for (const file of args) {
  const [line, ok] = await validateOne(file);
  process.stdout.write(JSON.stringify(line) + "\n");
  if (!ok) code = 1;
}
// Not process.exit(): that ends the process before a piped stdout is
// drained, cutting a long report at 64 KiB.
process.exitCode = code;
