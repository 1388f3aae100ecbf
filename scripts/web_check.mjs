// Do the cracks show in a web viewer? three.js' GLTFLoader in headless
// Chromium renders the uncracked input (converted to GLB by `crackle
// convert`) and the cracked output from the same camera, with the output's
// crack LINES hidden (only the surface and its maps are judged); the check
// is the one of scripts/render_check.py: at least 0.5% of the pixels change
// and at least 90% of the changed pixels lie within 4 pixels of the visible
// cracks: the crack lines (projected; hidden parts removed with a depth
// pass) and the visible gaps (faces of the crack_wall material). The share
// near the lines alone is printed as near_lines.
//   node scripts/web_check.mjs REFERENCE.glb OUTPUT.glb PREFIX [REF2 OUT2 PREFIX2 ...]
// Writes PREFIX-web.png (the output's render) and PREFIX-web-diff.png
// (changed pixels near crack lines red, away from them yellow, visible
// crack lines blue); prints one WEB_CHECK JSON line
// per pair; exits 1 when a check fails. Needs tools/web (scripts/web_check.sh
// installs three and puppeteer-core there) and Chromium (apt: chromium).
import http from "node:http";
import fs from "node:fs";
import path from "node:path";
import { createRequire } from "node:module";
import { fileURLToPath } from "node:url";

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), "..");
const web = path.join(root, "tools", "web", "node_modules");
const require = createRequire(path.join(web, "x.js"));
const puppeteer = require("puppeteer-core");

const args = process.argv.slice(2);
if (args.length < 3 || args.length % 3 !== 0) {
  console.error("usage: node scripts/web_check.mjs REFERENCE.glb OUTPUT.glb PREFIX [...]");
  process.exit(2);
}

const PAGE = `<!doctype html><html><body style="margin:0">
<script type="importmap">{"imports":{"three":"/three/build/three.module.js","three/addons/":"/three/examples/jsm/"}}</script>
<script type="module">
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { RoomEnvironment } from "three/addons/environments/RoomEnvironment.js";
const W = 800, H = 600, NEAR_PX = 4, THRESHOLD = 0.08 * 255, WALL = "crack_wall";
const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(W, H);
document.body.appendChild(renderer.domElement);
const gl = renderer.getContext();
// Image-based lighting, as web viewers set up (metals are black without it).
const environment = new THREE.PMREMGenerator(renderer).fromScene(new RoomEnvironment(), 0.04).texture;
const load = async (url) => (await new GLTFLoader().loadAsync(url)).scene;
function stage(root) {
  const s = new THREE.Scene();
  s.background = new THREE.Color(0.8, 0.8, 0.85);
  s.environment = environment;
  s.add(new THREE.HemisphereLight(0xffffff, 0x444444, 0.5));
  const sun = new THREE.DirectionalLight(0xffffff, 1.0);
  sun.position.set(1, 2, 1.5);
  s.add(sun);
  s.add(root);
  return s;
}
function read() {
  const px = new Uint8Array(W * H * 4);
  gl.readPixels(0, 0, W, H, gl.RGBA, gl.UNSIGNED_BYTE, px);
  return px; // row 0 at the bottom
}
try {
  const a = await load("/a.glb");
  const b = await load("/b.glb");
  const box = new THREE.Box3().setFromObject(a);
  const c = box.getCenter(new THREE.Vector3());
  const r = box.getSize(new THREE.Vector3()).length() / 2;
  const cam = new THREE.PerspectiveCamera(34, W / H, r * 0.05, r * 10);
  const e = 25 * Math.PI / 180, az = 35 * Math.PI / 180, d = 2.6 * r;
  cam.position.set(c.x + d * Math.cos(e) * Math.sin(az), c.y + d * Math.sin(e), c.z + d * Math.cos(e) * Math.cos(az));
  cam.lookAt(c);
  cam.updateMatrixWorld();
  renderer.render(stage(a), cam);
  const pa = read();
  const lines = [];
  b.traverse((o) => { if (o.isLineSegments || o.isLine || o.isPoints) lines.push(o); });
  lines.forEach((o) => (o.visible = false));
  const sb = stage(b);
  renderer.render(sb, cam);
  const pb = read();
  // Linear view depth over the far plane, 24 bits in RGB.
  sb.overrideMaterial = new THREE.ShaderMaterial({
    uniforms: { far: { value: cam.far } },
    vertexShader: "varying float z; void main() { vec4 v = modelViewMatrix * vec4(position, 1.0); z = -v.z; gl_Position = projectionMatrix * v; }",
    fragmentShader: "uniform float far; varying float z; void main() { float t = clamp(z / far, 0.0, 1.0) * 16777215.0; gl_FragColor = vec4(floor(t / 65536.0) / 255.0, mod(floor(t / 256.0), 256.0) / 255.0, mod(t, 256.0) / 255.0, 1.0); }",
    side: THREE.DoubleSide,
  });
  sb.background = new THREE.Color(1, 1, 1);
  renderer.render(sb, cam);
  const pd = read();
  const depthAt = (x, y) => { const k = 4 * ((H - 1 - y) * W + x); return (pd[k] * 65536 + pd[k + 1] * 256 + pd[k + 2]) / 16777215 * cam.far; };
  const mask = new Uint8Array(W * H);
  let samples = 0;
  const p = new THREE.Vector3(), q = new THREE.Vector3(), s = new THREE.Vector3();
  const view = new THREE.Vector3();
  const tol = 4e-3 * r;
  for (const o of lines) {
    const pos = o.geometry.getAttribute("position");
    for (let i = 0; i + 1 < pos.count; i += 2) {
      p.fromBufferAttribute(pos, i).applyMatrix4(o.matrixWorld);
      q.fromBufferAttribute(pos, i + 1).applyMatrix4(o.matrixWorld);
      const a2 = p.clone().project(cam), b2 = q.clone().project(cam);
      const n = Math.max(2, Math.ceil(Math.max(Math.abs(a2.x - b2.x) * W, Math.abs(a2.y - b2.y) * H)) + 1);
      for (let k = 0; k < n; k++) {
        s.lerpVectors(p, q, k / (n - 1));
        view.copy(s).applyMatrix4(cam.matrixWorldInverse);
        const ndc = s.clone().project(cam);
        const x = Math.floor((ndc.x * 0.5 + 0.5) * W), y = Math.floor((0.5 - ndc.y * 0.5) * H);
        if (x < 0 || y < 0 || x >= W || y >= H || ndc.z > 1) continue;
        samples++;
        if (-view.z > depthAt(x, y) + tol) continue; // hidden
        mask[y * W + x] = 1;
      }
    }
  }
  // The visible gaps: faces of the wall material (WALL), white on black.
  // A gap wider than a few pixels is part of its crack, whose line runs
  // along the gap's middle: its sides count as the crack's too.
  sb.overrideMaterial = null;
  sb.background = new THREE.Color(0, 0, 0);
  const white = new THREE.MeshBasicMaterial({ color: 0xffffff, side: THREE.DoubleSide });
  const black = new THREE.MeshBasicMaterial({ color: 0x000000, side: THREE.DoubleSide });
  const saved = [];
  sb.traverse((o) => {
    if (!o.isMesh) return;
    saved.push([o, o.material]);
    const m = Array.isArray(o.material) ? o.material[0] : o.material;
    o.material = m && m.name === WALL ? white : black;
  });
  renderer.render(sb, cam);
  const pg = read();
  saved.forEach(([o, m]) => (o.material = m));
  const gap = new Uint8Array(W * H);
  for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) gap[y * W + x] = pg[4 * ((H - 1 - y) * W + x)] > 127 ? 1 : 0;
  // Grow a mask by NEAR_PX.
  const grow = (m) => {
    const g = new Uint8Array(W * H);
    for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) {
      if (!m[y * W + x]) continue;
      for (let dy = -NEAR_PX; dy <= NEAR_PX; dy++) for (let dx = -NEAR_PX; dx <= NEAR_PX; dx++) {
        if (dx * dx + dy * dy > NEAR_PX * NEAR_PX) continue;
        const xx = x + dx, yy = y + dy;
        if (xx >= 0 && yy >= 0 && xx < W && yy < H) g[yy * W + xx] = 1;
      }
    }
    return g;
  };
  const nearLines = grow(mask);
  const near = grow(mask.map((v, i) => v | gap[i]));
  let changed = 0, close = 0, closeLines = 0, linePx = 0, gapPx = 0;
  for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) {
    const k = 4 * ((H - 1 - y) * W + x);
    const diff = Math.max(Math.abs(pa[k] - pb[k]), Math.abs(pa[k + 1] - pb[k + 1]), Math.abs(pa[k + 2] - pb[k + 2]));
    if (mask[y * W + x]) linePx++;
    if (gap[y * W + x]) gapPx++;
    if (diff > THRESHOLD) { changed++; if (near[y * W + x]) close++; if (nearLines[y * W + x]) closeLines++; }
  }
  // The difference as a picture: changed pixels near crack lines red,
  // changed pixels away from them yellow, crack lines blue.
  const canvas = document.createElement("canvas");
  canvas.width = W;
  canvas.height = H;
  const g2 = canvas.getContext("2d");
  const img = g2.createImageData(W, H);
  for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) {
    const k = 4 * ((H - 1 - y) * W + x), o = 4 * (y * W + x);
    const diff = Math.max(Math.abs(pa[k] - pb[k]), Math.abs(pa[k + 1] - pb[k + 1]), Math.abs(pa[k + 2] - pb[k + 2]));
    const px = diff > THRESHOLD ? (near[y * W + x] ? [255, 25, 25] : [255, 230, 0]) : mask[y * W + x] ? [25, 50, 255] : [pb[k] >> 1, pb[k + 1] >> 1, pb[k + 2] >> 1];
    img.data.set([...px, 255], o);
  }
  g2.putImageData(img, 0, 0);
  window.diffPng = canvas.toDataURL("image/png");
  sb.background = new THREE.Color(0.8, 0.8, 0.85);
  renderer.render(sb, cam);
  window.result = { changed: changed / (W * H), near_cracks: close / Math.max(changed, 1), near_lines: closeLines / Math.max(changed, 1), line_pixels: linePx, gap_pixels: gapPx, line_samples: samples };
} catch (err) {
  window.result = { error: String(err && err.stack || err) };
}
</script></body></html>`;

function serve(files) {
  const types = { ".js": "text/javascript", ".glb": "model/gltf-binary", ".html": "text/html" };
  return http.createServer((req, res) => {
    const url = decodeURIComponent(req.url.split("?")[0]);
    let file = null;
    if (url === "/") {
      res.writeHead(200, { "content-type": "text/html" });
      return res.end(PAGE);
    } else if (url === "/a.glb" || url === "/b.glb") {
      file = files[url];
    } else if (url.startsWith("/three/")) {
      const f = path.normalize(path.join(web, "three", url.slice("/three/".length)));
      if (f.startsWith(path.join(web, "three") + path.sep)) file = f;
    }
    if (!file || !fs.existsSync(file)) {
      res.writeHead(404);
      return res.end();
    }
    res.writeHead(200, { "content-type": types[path.extname(file)] || "application/octet-stream" });
    fs.createReadStream(file).pipe(res);
  });
}

const browser = await puppeteer.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  headless: true,
  args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"],
});
let failed = 0;
for (let i = 0; i < args.length; i += 3) {
  const [ref, out, prefix] = args.slice(i, i + 3);
  const files = { "/a.glb": path.resolve(ref), "/b.glb": path.resolve(out) };
  const server = serve(files);
  await new Promise((ok) => server.listen(0, "127.0.0.1", ok));
  const page = await browser.newPage();
  await page.setViewport({ width: 800, height: 600 });
  await page.goto(`http://127.0.0.1:${server.address().port}/`);
  await page.waitForFunction("window.result !== undefined", { timeout: 300000 });
  const result = await page.evaluate("window.result");
  await page.screenshot({ path: `${prefix}-web.png` });
  const diff = await page.evaluate("window.diffPng || ''");
  if (diff) fs.writeFileSync(`${prefix}-web-diff.png`, Buffer.from(diff.split(",")[1], "base64"));
  await page.close();
  server.close();
  const ok = !result.error && result.changed >= 0.005 && result.near_cracks >= 0.9;
  if (!ok) failed++;
  console.log("WEB_CHECK " + JSON.stringify({ reference: ref, output: out, ...result, ok }));
}
await browser.close();
process.exit(failed ? 1 : 0);
