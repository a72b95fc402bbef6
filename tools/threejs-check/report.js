// Runs in the page (page.html): loads /asset?... with three.js's GLTFLoader, plays the first
// animation with an AnimationMixer frame by frame (mixer.setTime) and stores a JSON report in
// `window.__report` for check.mjs to read. See check.mjs for the report's fields.
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { MeshoptDecoder } from "three/addons/libs/meshopt_decoder.module.js";

const params = new URLSearchParams(location.search);

function box(points) {
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (const p of points) {
    for (let k = 0; k < 3; k++) {
      lo[k] = Math.min(lo[k], p[k]);
      hi[k] = Math.max(hi[k], p[k]);
    }
  }
  return { min: lo, max: hi };
}

// World-space positions of a mesh as drawn now: three's own CPU path (Mesh.getVertexPosition)
// applies the morph targets with the current morphTargetInfluences (relative or absolute
// targets, normalized/quantized attributes de-quantized) and, for a SkinnedMesh, the bones;
// then the node's world matrix (which also undoes a quantization transform on the node).
function worldPositions(mesh) {
  const n = mesh.geometry.attributes.position.count;
  const v = new THREE.Vector3();
  const out = new Array(n);
  for (let i = 0; i < n; i++) {
    mesh.getVertexPosition(i, v);
    v.applyMatrix4(mesh.matrixWorld);
    out[i] = [v.x, v.y, v.z];
  }
  return out;
}

function materialReport(m) {
  const img = m.map ? m.map.image : null;
  // Every texture slot that holds a decoded image of nonzero size.
  const maps = ["map", "metalnessMap", "roughnessMap", "normalMap", "aoMap", "emissiveMap"];
  return {
    name: m.name,
    type: m.type,
    map: !!m.map,
    mapSize: img ? [img.width || 0, img.height || 0] : [0, 0],
    maps: maps.filter((k) => m[k] && m[k].image && m[k].image.width > 0),
    // The UV set each of those samples.
    channels: Object.fromEntries(maps.filter((k) => m[k]).map((k) => [k, m[k].channel ?? 0])),
    normalScale: m.normalScale ? [m.normalScale.x, m.normalScale.y] : null,
    aoMapIntensity: m.aoMapIntensity ?? null,
  };
}

async function main() {
  const file = params.get("file");
  const wantPositions = params.get("positions") === "1";
  // EXT_meshopt_compression files (bsarap export --meshopt) need the decoder; others ignore it.
  const gltf = await new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).loadAsync(file);
  const scene = gltf.scene;
  scene.updateMatrixWorld(true);
  const meshes = [];
  scene.traverse((o) => {
    if (o.isMesh) meshes.push(o);
  });
  const clip = gltf.animations[0] || null;
  let times = [];
  if (params.get("times")) {
    times = params.get("times").split(",").map(Number);
  } else if (clip) {
    const all = new Set();
    for (const t of clip.tracks) for (const x of t.times) all.add(x);
    times = [...all].sort((a, b) => a - b);
  }
  const mixer = new THREE.AnimationMixer(scene);
  if (clip) {
    const action = mixer.clipAction(clip);
    // Play once and hold the last pose: with LoopRepeat, t = duration would wrap to frame 0.
    action.setLoop(THREE.LoopOnce, 1);
    action.clampWhenFinished = true;
    action.play();
  }
  const samples = [];
  for (const t of times) {
    mixer.setTime(t);
    scene.updateMatrixWorld(true);
    samples.push(
      meshes.map((m) => {
        const pts = worldPositions(m);
        const s = box(pts);
        s.influences = m.morphTargetInfluences ? Array.from(m.morphTargetInfluences) : [];
        if (wantPositions) s.positions = pts;
        return s;
      }),
    );
  }
  window.__report = {
    three: THREE.REVISION,
    meshes: meshes.map((m) => {
      const g = m.geometry;
      const mats = Array.isArray(m.material) ? m.material : [m.material];
      return {
        name: m.name,
        skinned: !!m.isSkinnedMesh,
        vertices: g.attributes.position.count,
        triangles: g.index ? g.index.count / 3 : g.attributes.position.count / 3,
        uv: !!g.attributes.uv,
        morphTargets: g.morphAttributes.position ? g.morphAttributes.position.length : 0,
        morphTargetsRelative: g.morphTargetsRelative,
        materials: mats.map(materialReport),
      };
    }),
    animations: gltf.animations.map((a) => ({
      name: a.name,
      duration: a.duration,
      tracks: a.tracks.map((t) => ({ name: t.name, keys: t.times.length })),
    })),
    times,
    samples,
  };
}

main().catch((e) => {
  window.__report = { error: String(e && e.stack ? e.stack : e) };
});
