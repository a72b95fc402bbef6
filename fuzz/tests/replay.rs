//! Replays every fuzz target's body (`solver_fuzz::run`) on stable, as an ordinary test, within
//! a fixed budget: the target's cargo-fuzz crash artifacts and at most [`CORPUS_CAP`] files of
//! its corpus when there are any (`fuzz/corpus/NAME/`, `fuzz/artifacts/NAME/`, not in git;
//! `BSARAP_FUZZ_CORPUS=all` replays the whole corpus), its valid seed files
//! (`solver_fuzz::seeds`, each of which its reader must accept), and `MUTANTS` seeded mutations
//! of them (bytes changed, inserted, deleted, duplicated, truncated, and two seeds spliced).
//!
//! A body that panics fails the test, which names the target and the seed and writes the input
//! under the test's temporary folder for `cargo fuzz run NAME FILE`. Over the mutants, each
//! reader must both accept some and refuse some, so the inputs reach both paths.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use solver::io::{Format, load_mesh_from_bytes};
use solver_fuzz::seeds::{seeds, write_corpus};
use solver_fuzz::{TARGETS, run};

/// Mutated inputs per target: about 0.1 s per target in the test profile.
const MUTANTS: usize = 3000;

/// Corpus files replayed per target: a long cargo-fuzz run leaves thousands, which would make
/// the test command as long as the run. Crash artifacts are all replayed.
const CORPUS_CAP: usize = 500;

#[test]
fn every_target_survives_its_corpus_seeds_and_mutants() {
    for name in TARGETS {
        let seeds = seeds(name);
        assert!(!seeds.is_empty(), "{name}: no seeds");
        for (i, seed) in seeds.iter().enumerate() {
            assert!(
                check(name, seed, &format!("seed {i}")),
                "{name}: seed {i} is refused{}",
                why(name, seed)
            );
        }
        let all = std::env::var("BSARAP_FUZZ_CORPUS").is_ok_and(|v| v == "all");
        let corpus = local_files("corpus", name);
        let (files, left) =
            replayed(corpus, local_files("artifacts", name), (!all).then_some(CORPUS_CAP));
        if left > 0 {
            eprintln!("{name}: {left} corpus files not replayed (BSARAP_FUZZ_CORPUS=all)");
        }
        for file in files {
            let bytes = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            check(name, &bytes, &file.display().to_string());
        }
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15
            ^ name.bytes().fold(0u64, |h, b| h.wrapping_mul(31) + u64::from(b)));
        let (mut accepted, mut refused) = (0, 0);
        for k in 0..MUTANTS {
            let s = rng.below(seeds.len());
            let other = &seeds[rng.below(seeds.len())];
            let mut bytes = seeds[s].clone();
            for _ in 0..1 + rng.below(4) {
                mutate(&mut bytes, other, &mut rng);
            }
            if check(name, &bytes, &format!("mutant {k} of seed {s}")) {
                accepted += 1;
            } else {
                refused += 1;
            }
        }
        eprintln!("{name}: {} seeds, {accepted} mutants accepted, {refused} refused", seeds.len());
        assert!(accepted > 0 && refused > 0, "{name}: {accepted} accepted, {refused} refused");
    }
}

#[test]
fn the_seed_corpus_holds_every_targets_seeds() {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-seed-corpus");
    let _ = std::fs::remove_dir_all(&root);
    let written = write_corpus(&root).unwrap();
    assert_eq!(written, TARGETS.iter().map(|name| seeds(name).len()).sum::<usize>());
    for name in TARGETS {
        for (i, seed) in seeds(name).iter().enumerate() {
            let file = root.join(name).join(format!("seed-{i}"));
            assert_eq!(&std::fs::read(&file).unwrap(), seed, "{}", file.display());
        }
    }
}

/// Runs target `name` on `bytes`; on a panic, saves the input and fails naming it.
fn check(name: &str, bytes: &[u8], what: &str) -> bool {
    match catch_unwind(AssertUnwindSafe(|| run(name, bytes))) {
        Ok(Some(accepted)) => accepted,
        Ok(None) => panic!("no fuzz target {name}"),
        Err(_) => {
            let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-replay");
            let file = dir.join(format!("{name}-{}", what.replace([' ', '/'], "-")));
            let saved = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&file, bytes));
            panic!("{name} panicked on {what} (input saved: {saved:?} at {})", file.display());
        }
    }
}

/// The mesh reader's error for a refused mesh file (empty for the other targets).
fn why(name: &str, bytes: &[u8]) -> String {
    let format = match name {
        "obj" => Format::Obj,
        "off" => Format::Off,
        "ply" => Format::Ply,
        "stl" => Format::Stl,
        "gltf" => Format::Gltf,
        _ => return String::new(),
    };
    match load_mesh_from_bytes(bytes, format, "seed") {
        Err(e) => format!(": {e}"),
        Ok(_) => String::new(),
    }
}

/// The files of `fuzz/KIND/NAME/` (`corpus`, or `artifacts`: what cargo-fuzz saved of its
/// crashes), where present, in name order.
fn local_files(kind: &str, name: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(kind).join(name);
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

/// What to replay: every artifact, then the corpus up to `cap` files (`None`: all of it),
/// taken evenly over it (libFuzzer names files by their hash, so name order is no order of
/// age or size); with how many corpus files are left out.
fn replayed(
    corpus: Vec<PathBuf>,
    artifacts: Vec<PathBuf>,
    cap: Option<usize>,
) -> (Vec<PathBuf>, usize) {
    let n = corpus.len();
    let keep = cap.map_or(n, |c| c.min(n));
    let mut files = artifacts;
    files.extend((0..keep).map(|k| corpus[k * n / keep.max(1)].clone()));
    (files, n - keep)
}

#[test]
fn the_replay_keeps_every_artifact_and_caps_the_corpus() {
    let paths = |prefix: &str, n: usize| -> Vec<PathBuf> {
        (0..n).map(|i| PathBuf::from(format!("{prefix}-{i:04}"))).collect()
    };
    let (files, left) = replayed(paths("c", 1200), paths("crash", 3), Some(500));
    assert_eq!((files.len(), left), (503, 700));
    assert_eq!(files[..3], paths("crash", 3)[..]);
    let mut sampled = files[3..].to_vec();
    sampled.dedup();
    assert_eq!(sampled.len(), 500, "a corpus file taken twice");
    assert_eq!(sampled[0], PathBuf::from("c-0000"));
    assert!(sampled[499].as_path() >= Path::new("c-1190"), "not spread over the corpus");
    let (files, left) = replayed(paths("c", 40), Vec::new(), Some(500));
    assert_eq!((files, left), (paths("c", 40), 0));
    let (files, left) = replayed(paths("c", 1200), Vec::new(), None);
    assert_eq!((files.len(), left), (1200, 0));
}

/// A xorshift64 generator: the same inputs on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform in `0..n` (`0` when `n` is 0).
    fn below(&mut self, n: usize) -> usize {
        if n == 0 { 0 } else { (self.next() % n as u64) as usize }
    }
}

/// Bytes a reader treats specially: digits, signs, separators, JSON punctuation, high bytes.
const SPECIAL: &[u8] = b"0123456789-+.eE /\n\r\t{}[]\":,#\0\xff\x80";

/// Tokens at the edges of what the readers accept: counts, indices and floats.
const TOKENS: [&str; 12] = [
    "-1",
    "0",
    "65536",
    "4294967295",
    "18446744073709551615",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "1e-320",
    " 3 ",
    "\n",
];

/// Applies one random edit to `bytes`; `other` is a seed of the same target to splice from.
fn mutate(bytes: &mut Vec<u8>, other: &[u8], rng: &mut Rng) {
    let len = bytes.len();
    let at = rng.below(len + 1);
    match rng.below(9) {
        0 if len > 0 => bytes[at.min(len - 1)] ^= 1 << rng.below(8),
        1 if len > 0 => bytes[at.min(len - 1)] = rng.next() as u8,
        2 if len > 0 => bytes[at.min(len - 1)] = SPECIAL[rng.below(SPECIAL.len())],
        3 => bytes.splice(at..at, TOKENS[rng.below(TOKENS.len())].bytes()).for_each(drop),
        4 => bytes.truncate(at),
        5 => {
            let end = (at + 1 + rng.below(64)).min(len);
            bytes.drain(at.min(end)..end);
        }
        6 => {
            let end = (at + 1 + rng.below(64)).min(len);
            let chunk = bytes[at.min(end)..end].to_vec();
            bytes.splice(at..at, chunk).for_each(drop);
        }
        7 => {
            // A prefix of this seed, then a suffix of the other.
            let from = rng.below(other.len() + 1);
            bytes.truncate(at);
            bytes.extend_from_slice(&other[from..]);
        }
        _ if at + 4 <= len => {
            // A little-endian u32 at the edge of a count or length field.
            let v = [0, 1, 0x7FFF_FFFF, 0x8000_0000, u32::MAX, len as u32][rng.below(6)];
            bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        _ => bytes.push(SPECIAL[rng.below(SPECIAL.len())]),
    }
}
