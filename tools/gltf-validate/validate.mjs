// Validates one glTF/GLB file with the Khronos glTF validator and prints its JSON report.
// Usage: node tools/gltf-validate/validate.mjs FILE.glb|FILE.gltf
// Exit status: 0 when the report has no errors, 1 when it has, 2 when the file cannot be read.
import { readFile } from "node:fs/promises";
import { createRequire } from "node:module";

const require = createRequire(import.meta.url);
const validator = require("gltf-validator");

const file = process.argv[2];
if (!file) {
  console.error("usage: node validate.mjs FILE.glb|FILE.gltf");
  process.exit(2);
}
let data;
try {
  data = new Uint8Array(await readFile(file));
} catch (e) {
  console.error(`${file}: cannot read: ${e.message}`);
  process.exit(2);
}
const report = await validator.validateBytes(data, {
  uri: file,
  maxIssues: 100,
  // Embedded data URIs only: an external resource is reported, not fetched.
  externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri} not allowed`)),
});
console.log(JSON.stringify(report, null, 2));
process.exit(report.issues.numErrors === 0 ? 0 : 1);
