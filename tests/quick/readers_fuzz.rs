//! No panic on any input: the readers of every log format (measured CSV + JSON, drive-sim MCAP,
//! rosbag2 bags through `log::open`) and the TOML loaders (robot, terrain, sweep matrix) under
//! generated input — random bytes, and valid files with bytes flipped, inserted and cut off.
//!
//! Each property runs a fixed budget of cases (`DRIVE_SIM_FUZZ_CASES`, default 64), so CI
//! time stays bounded; raise it locally for a longer fuzzing session, e.g.
//! `DRIVE_SIM_FUZZ_CASES=5000 cargo test --release --test quick readers_fuzz::`.

use drive_sim::config::parse_toml;
use drive_sim::harness::sweep::SweepMatrix;
use drive_sim::log::mcap::{decode_mcap, encode_mcap};
use drive_sim::log::{Frame, LogMeta, Nominal, Origin, Phase};
use drive_sim::protocol::{run_drive, sampler::UniformWheel, ProtocolConfig};
use drive_sim::robot::{Robot, BUILTIN_ROBOTS};
use drive_sim::sim::IdealPlant;
use drive_sim::terrain::{Terrain, BUILTIN_TERRAINS};
use proptest::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

const MEASURED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");

fn cases() -> u32 {
    std::env::var("DRIVE_SIM_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(64)
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: cases(),
        // Shrinking a failure is worth it, but bounded.
        max_shrink_iters: 256,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Edits of a valid input: byte overwrites, insertions, and a cut-off length.
#[derive(Debug, Clone)]
struct Mutation {
    writes: Vec<(usize, u8)>,
    inserts: Vec<(usize, Vec<u8>)>,
    keep: Option<usize>,
}

fn mutation() -> impl Strategy<Value = Mutation> {
    (
        prop::collection::vec((any::<usize>(), any::<u8>()), 0..8),
        prop::collection::vec((any::<usize>(), prop::collection::vec(any::<u8>(), 1..16)), 0..3),
        prop::option::of(any::<usize>()),
    )
        .prop_map(|(writes, inserts, keep)| Mutation {
            writes,
            inserts,
            keep,
        })
}

impl Mutation {
    fn apply(&self, input: &[u8]) -> Vec<u8> {
        let mut b = input.to_vec();
        if b.is_empty() {
            return b;
        }
        for (i, v) in &self.writes {
            let n = b.len();
            b[i % n] = *v;
        }
        for (i, bytes) in &self.inserts {
            let at = i % (b.len() + 1);
            b.splice(at..at, bytes.iter().copied());
        }
        if let Some(k) = self.keep {
            b.truncate(k % (b.len() + 1));
        }
        b
    }
}

/// Mutations that keep text valid UTF-8 by editing at character level: digits, signs and
/// punctuation that turn numbers into other numbers, and keys into other keys.
fn text_mutation() -> impl Strategy<Value = Vec<(usize, char)>> {
    prop::collection::vec(
        (
            any::<usize>(),
            prop::sample::select(vec![
                '0', '1', '9', '-', '.', 'e', '+', '"', ',', '=', '[', ']', '{', '}', '\n', 'x', ' ', '#',
            ]),
        ),
        1..10,
    )
}

fn apply_text(text: &str, edits: &[(usize, char)]) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for (i, c) in edits {
        if chars.is_empty() {
            break;
        }
        let n = chars.len();
        chars[i % n] = *c;
    }
    chars.into_iter().collect()
}

/// A short DRIVE log on the ideal plant, encoded as MCAP (once).
fn valid_mcap() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| {
        let (robot, _) = Robot::resolve("husky").unwrap();
        let mut plant = IdealPlant::new(robot.idd(), 0.1);
        let mut sampler = UniformWheel::new(1);
        let cfg = ProtocolConfig {
            steps: 2,
            ..Default::default()
        };
        let mut frames: Vec<Frame> = Vec::new();
        run_drive(&mut plant, &robot, &mut sampler, &cfg, &mut frames).unwrap();
        let meta = LogMeta {
            name: "fuzz".into(),
            robot: "husky".into(),
            terrain: "asphalt".into(),
            rate_hz: cfg.rate_hz,
            window_s: cfg.window_s,
            windows_per_step: cfg.windows_per_step,
            samples_per_window: cfg.samples_per_window(),
            nominal: Nominal::from_robot(&robot),
            origin: Origin::Simulated {
                seed: 1,
                robot_file: String::new(),
                terrain_file: String::new(),
                sampler: "uniform-wheel".into(),
                injected: vec![],
            },
        };
        assert!(frames.iter().any(|f| matches!(f.phase, Phase::Step { .. })));
        encode_mcap(&meta, &frames, Path::new("fuzz.mcap")).unwrap()
    })
}

/// The first 400 lines of a measured CSV and its JSON (once).
fn measured() -> &'static (String, String) {
    static TEXT: OnceLock<(String, String)> = OnceLock::new();
    TEXT.get_or_init(|| {
        let csv = std::fs::read_to_string(format!("{MEASURED}/warthog_gravel.csv")).unwrap();
        let head: Vec<&str> = csv.lines().take(400).collect();
        let json = std::fs::read_to_string(format!("{MEASURED}/warthog_gravel.json")).unwrap();
        (head.join("\n") + "\n", json)
    })
}

/// Opens `bytes` as a file named `name` through `log::open` (the path every command uses).
fn open_bytes(name: &str, bytes: &[u8], json: Option<&[u8]>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    if let Some(j) = json {
        std::fs::write(path.with_extension("json"), j).unwrap();
    }
    let _ = drive_sim::log::open(&path, &Default::default());
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn mcap_decoder_survives_corruption(m in mutation()) {
        let bytes = m.apply(valid_mcap());
        let _ = decode_mcap(&bytes, Path::new("fuzz.mcap"));
    }

    #[test]
    fn mcap_and_bag_readers_survive_random_bytes(bytes in prop::collection::vec(any::<u8>(), 0..4096), db3 in any::<bool>()) {
        // Random bytes behind an MCAP magic reach the record parser, not just the magic check.
        let mut b = b"\x89MCAP0\r\n".to_vec();
        b.extend_from_slice(&bytes);
        open_bytes("x.mcap", &b, None);
        if db3 {
            open_bytes("x.db3", &bytes, None);
        } else {
            // A bag directory whose metadata.yaml is garbage.
            let dir = tempfile::tempdir().unwrap();
            std::fs::write(dir.path().join("metadata.yaml"), &bytes).unwrap();
            let _ = drive_sim::log::open(dir.path(), &Default::default());
        }
    }

    #[test]
    fn measured_csv_reader_survives_edits(csv_edits in text_mutation(), json_edits in text_mutation(), cut in any::<usize>()) {
        let (csv, json) = measured();
        let mut csv = apply_text(csv, &csv_edits);
        let keep = cut % (csv.len() + 1);
        if csv.is_char_boundary(keep) {
            csv.truncate(keep);
        }
        let json = apply_text(json, &json_edits);
        open_bytes("m.csv", csv.as_bytes(), Some(json.as_bytes()));
    }

    #[test]
    fn measured_csv_reader_survives_random_bytes(csv in prop::collection::vec(any::<u8>(), 0..2048), json in prop::collection::vec(any::<u8>(), 0..512)) {
        open_bytes("m.csv", &csv, Some(&json));
    }

    #[test]
    fn toml_loaders_survive_edits(edits in text_mutation(), which in 0usize..4) {
        let text = match which {
            0 => BUILTIN_ROBOTS[0].1.to_string(),
            1 => BUILTIN_ROBOTS[1].1.to_string(),
            2 => BUILTIN_TERRAINS[0].1.to_string(),
            _ => std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/sweeps/example.toml")).unwrap(),
        };
        let text = apply_text(&text, &edits);
        let f = Path::new("fuzz.toml");
        let _ = parse_toml::<Robot>(&text, f);
        let _ = parse_toml::<Terrain>(&text, f);
        let _ = SweepMatrix::parse(&text, f);
    }

    #[test]
    fn toml_loaders_survive_random_text(text in "\\PC{0,600}") {
        let f = Path::new("fuzz.toml");
        let _ = parse_toml::<Robot>(&text, f);
        let _ = parse_toml::<Terrain>(&text, f);
        let _ = SweepMatrix::parse(&text, f);
    }
}

/// The valid inputs the mutations start from do load (so the properties test corruption, not
/// a reader that rejects everything).
#[test]
fn the_seeds_of_the_mutations_are_valid() {
    decode_mcap(valid_mcap(), Path::new("fuzz.mcap")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (csv, json) = measured();
    let path = dir.path().join("m.csv");
    std::fs::write(&path, csv).unwrap();
    std::fs::write(path.with_extension("json"), json).unwrap();
    drive_sim::log::open(&path, &Default::default()).unwrap();
}
