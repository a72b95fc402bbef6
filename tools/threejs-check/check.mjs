// Opens a glTF file the way a web viewer does: three.js's GLTFLoader (with three's
// MeshoptDecoder, for EXT_meshopt_compression) in headless Chromium,
// then plays its first animation with an AnimationMixer, frame by frame, and prints a JSON
// report on stdout.
//
// Usage: node tools/threejs-check/check.mjs FILE.glb|FILE.gltf [--positions] [--times=t0,t1,...]
// Environment: CHROMIUM = the browser binary (default /usr/bin/chromium).
//
// Report: { three: revision,
//   meshes: [{ name, skinned, vertices, triangles, uv, morphTargets, morphTargetsRelative,
//              materials: [{ name, type, map (has a base-colour texture), mapSize: [w, h],
//                            maps (the slots holding a decoded image: map, metalnessMap,
//                            roughnessMap, normalMap, aoMap, emissiveMap), channels (the UV
//                            set of each: { map: 0, ... }), normalScale: [x, y],
//                            aoMapIntensity }] }],
//   animations: [{ name, duration, tracks: [{ name, keys }] }],
//   times: the sampled times (default: every key time of the first animation),
//   samples: per time, per mesh: { min, max (world-space bounding box), influences,
//            positions (with --positions: world-space [x, y, z] per vertex) } }
// Positions are computed on the CPU by three's Mesh.getVertexPosition (morph targets with the
// mixer's influences, skinning) and the node's world matrix, so no GPU is needed.
//
// Exit status: 0 with a report, 1 when three.js failed to load the file, 2 when the browser
// could not be started or the file read (the message says which).
import { createServer } from "node:http";
import { readFile } from "node:fs/promises";
import { dirname, extname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import puppeteer from "puppeteer-core";

const here = dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const file = args.find((a) => !a.startsWith("--"));
if (!file) {
  console.error("usage: node check.mjs FILE.glb|FILE.gltf [--positions] [--times=t0,t1,...]");
  process.exit(2);
}
const positions = args.includes("--positions");
const timesArg = args.find((a) => a.startsWith("--times="));

let asset;
try {
  asset = await readFile(resolve(file));
} catch (e) {
  console.error(`${file}: cannot read: ${e.message}`);
  process.exit(2);
}

const types = {
  ".html": "text/html",
  ".js": "text/javascript",
  ".glb": "model/gltf-binary",
  ".gltf": "model/gltf+json",
};
// Serves the page, report.js, three's modules and the asset (as /asset.EXT) on localhost:
// module scripts and fetch() need an http origin, and nothing leaves the machine.
const server = createServer(async (req, res) => {
  const path = decodeURIComponent(new URL(req.url, "http://x").pathname);
  let body = null;
  let type = types[extname(path)] || "application/octet-stream";
  try {
    if (path === "/" || path === "/page.html") body = await readFile(join(here, "page.html"));
    else if (path === "/report.js") body = await readFile(join(here, "report.js"));
    else if (path.startsWith("/asset")) body = asset;
    else if (path.startsWith("/three/") && !path.includes(".."))
      body = await readFile(join(here, "node_modules", path));
  } catch {
    body = null;
  }
  if (body === null) {
    res.writeHead(path === "/favicon.ico" ? 204 : 404).end();
    return;
  }
  res.writeHead(200, { "content-type": type }).end(body);
});
await new Promise((ok) => server.listen(0, "127.0.0.1", ok));
const port = server.address().port;

let browser;
try {
  browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    headless: true,
    // No sandbox (CI runs as root); no background connections (the network is closed).
    args: [
      "--no-sandbox",
      "--disable-gpu",
      "--disable-dev-shm-usage",
      "--no-first-run",
      "--disable-quic",
      "--disable-background-networking",
      "--disable-component-update",
      "--disable-sync",
    ],
  });
} catch (e) {
  console.error(`cannot start the browser: ${e.message}`);
  server.close();
  process.exit(2);
}

let status = 0;
try {
  const page = await browser.newPage();
  const logs = [];
  page.on("console", (m) => logs.push(`${m.type()}: ${m.text()}`));
  page.on("pageerror", (e) => logs.push(`pageerror: ${e.message}`));
  const q = new URLSearchParams({ file: `/asset${extname(file).toLowerCase()}` });
  if (positions) q.set("positions", "1");
  if (timesArg) q.set("times", timesArg.slice("--times=".length));
  await page.goto(`http://127.0.0.1:${port}/page.html?${q}`);
  await page.waitForFunction(() => window.__report !== undefined, { timeout: 60000 });
  const report = await page.evaluate(() => window.__report);
  report.console = logs;
  console.log(JSON.stringify(report));
  if (report.error) {
    console.error(`three.js could not load ${file}: ${report.error}`);
    status = 1;
  }
} catch (e) {
  console.error(`browser run failed: ${e.message}`);
  status = 2;
} finally {
  await browser.close();
  server.close();
}
process.exit(status);
