//! MCAP logs: a simulated run read back equals the in-memory log; the writer is deterministic
//! and crash-safe; damaged or foreign files give `Error::Log` naming where, never a panic.

use drive_sim::kinematics::BodyVelocity;
use drive_sim::log::mcap::{
    decode_mcap, encode_mcap, encode_mcap_with, partial_path, read_mcap, read_mcap_frames, write_mcap,
    Container, McapWriter, TOPIC_ICP_ODOM, TOPIC_IMU, TOPIC_MARKER, TOPIC_TRUTH_JOINTS, TOPIC_TRUTH_ODOM,
};
use drive_sim::log::{DriveLog, Frame, LogMeta, Nominal, Origin, Phase, Pose};
use drive_sim::protocol::{run_drive, sampler::UniformWheel, ProtocolConfig, RunSummary};
use drive_sim::robot::Robot;
use drive_sim::sim::IdealPlant;
use drive_sim::Error;
use std::collections::BTreeMap;
use std::path::Path;

fn meta(robot: &Robot, seed: u64) -> LogMeta {
    LogMeta {
        name: "husky_ideal".into(),
        robot: "husky".into(),
        terrain: "ideal".into(),
        rate_hz: 20.0,
        window_s: 2.0,
        windows_per_step: 3,
        samples_per_window: 40,
        nominal: Nominal::from_robot(robot),
        origin: Origin::Simulated {
            seed,
            robot_file: "robots/husky.toml".into(),
            terrain_file: "terrains/ideal.toml".into(),
            sampler: "uniform-wheel".into(),
            injected: vec!["motor_left=0.9".into()],
        },
    }
}

/// Runs DRIVE on the ideal Husky, streaming into `sink`.
fn run(steps: u32, seed: u64, sink: &mut dyn drive_sim::protocol::FrameSink) -> RunSummary {
    let (robot, _) = Robot::resolve("husky").unwrap();
    let mut plant = IdealPlant::new(robot.idd(), 0.1);
    let mut sampler = UniformWheel::new(seed);
    let cfg = ProtocolConfig {
        steps,
        ..Default::default()
    };
    run_drive(&mut plant, &robot, &mut sampler, &cfg, sink).unwrap()
}

fn husky() -> Robot {
    Robot::resolve("husky").unwrap().0
}

/// Angle difference wrapped to (-π, π].
fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    if d > std::f64::consts::PI {
        d - std::f64::consts::TAU
    } else {
        d
    }
}

/// Asserts the attitude of `got` is within 1e-12 rad of `want`, then copies `want`'s angles
/// into `got` so that everything else can be compared bit for bit.
fn align_angles(got: &mut Pose, want: &Pose, what: &str) {
    for (g, w) in [
        (got.roll_rad, want.roll_rad),
        (got.pitch_rad, want.pitch_rad),
        (got.yaw_rad, want.yaw_rad),
    ] {
        assert!(angle_diff(g, w).abs() < 1e-12, "{what}: {g} vs {w}");
    }
    got.roll_rad = want.roll_rad;
    got.pitch_rad = want.pitch_rad;
    got.yaw_rad = want.yaw_rad;
}

fn align_frames(got: &mut [Frame], want: &[Frame]) {
    assert_eq!(got.len(), want.len());
    for (i, (g, w)) in got.iter_mut().zip(want).enumerate() {
        align_angles(&mut g.m.pose, &w.m.pose, &format!("frame {i} pose"));
        if let (Some(gt), Some(wt)) = (g.m.truth.as_mut(), w.m.truth.as_ref()) {
            align_angles(&mut gt.pose, &wt.pose, &format!("frame {i} truth"));
        }
    }
}

#[test]
fn simulated_log_reads_back_as_the_in_memory_log() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("husky.mcap");
    let robot = husky();
    let meta = meta(&robot, 3);
    // Stream straight from the protocol into the writer, and keep a copy in memory.
    struct Both(McapWriter, Vec<Frame>);
    impl drive_sim::protocol::FrameSink for Both {
        fn frame(&mut self, f: &Frame) -> drive_sim::Result<()> {
            self.1.push(*f);
            self.0.write_frame(f)
        }
    }
    let mut sink = Both(McapWriter::create(&path, &meta).unwrap(), Vec::new());
    let summary = run(6, 3, &mut sink);
    let Both(writer, frames) = sink;
    assert!(!path.exists(), "final path exists before finish");
    assert!(writer.partial_path().exists());
    let s = writer.finish().unwrap();
    assert!(path.exists() && !partial_path(&path).exists());
    // The Husky's small area interrupts some of these steps: the log holds re-orientations.
    assert!(summary.interruptions > 0, "{summary:?}");
    assert!(frames.iter().any(|f| matches!(f.phase, Phase::Reorient { .. })));

    let n = frames.len() as u64;
    assert_eq!(s.frames, n);
    let expected_counts: BTreeMap<String, u64> = [
        "/cmd_vel",
        "/drive/marker",
        "/ground_truth/joint_states",
        "/ground_truth/odom",
        "/icp_odom",
        "/imu/data_raw",
        "/joint_states",
        "/tf",
        "/wheel_cmd",
    ]
    .iter()
    .map(|t| (t.to_string(), n))
    .collect();
    assert_eq!(s.messages_per_topic, expected_counts);
    assert_eq!(s.bytes, std::fs::metadata(&path).unwrap().len());

    let want = DriveLog::from_frames(meta.clone(), &frames);
    let mut got = read_mcap(&path).unwrap();
    assert_eq!(got.samples.len(), want.samples.len());
    for (i, (g, w)) in got.samples.iter_mut().zip(&want.samples).enumerate() {
        align_angles(&mut g.m.pose, &w.m.pose, &format!("sample {i}"));
        let (gt, wt) = (g.m.truth.as_mut().unwrap(), w.m.truth.as_ref().unwrap());
        align_angles(&mut gt.pose, &wt.pose, &format!("sample {i} truth"));
    }
    // Everything else, metadata included, is bit-identical.
    assert_eq!(got, want);
    assert_eq!(got.interruptions.len() as u32, summary.interruptions);

    let (meta2, mut frames2) = read_mcap_frames(&path).unwrap();
    assert_eq!(meta2, meta);
    align_frames(&mut frames2, &frames);
    assert_eq!(frames2, frames);
}

#[test]
fn measured_like_frames_without_truth_and_with_a_reference_round_trip() {
    let mut frames = Vec::new();
    run(1, 5, &mut frames);
    // What a real robot log gives: no ground truth; a body-velocity estimate on some ticks.
    for (i, f) in frames.iter_mut().enumerate() {
        f.m.truth = None;
        if i % 3 == 0 {
            f.m.reference = Some(BodyVelocity::new(0.1 * i as f64, -0.02, 0.3));
        }
        f.m.pose.roll_rad = 0.05;
        f.m.pose.pitch_rad = -0.1;
    }
    let robot = husky();
    let meta = LogMeta {
        origin: Origin::Measured {
            file: "warthog_ice.csv".into(),
        },
        ..meta(&robot, 0)
    };
    let bytes = encode_mcap(&meta, &frames, Path::new("mem.mcap")).unwrap();
    let (m2, mut got) = decode_mcap(&bytes, Path::new("mem.mcap")).unwrap();
    assert_eq!(m2, meta);
    align_frames(&mut got, &frames);
    assert_eq!(got, frames);
    // No ground-truth topics when there is no ground truth.
    let dir = tempfile::tempdir().unwrap();
    let s = write_mcap(dir.path().join("m.mcap"), &meta, &frames).unwrap();
    assert!(!s.messages_per_topic.contains_key(TOPIC_TRUTH_ODOM));
    assert_eq!(s.messages_per_topic.len(), 7);
}

/// Our container writer (whole records into the chunk, one zstd call per chunk) against the
/// `mcap` crate's writer on the same frames: the same records (schemas, channels, statistics,
/// chunk boundaries and sizes, message indexes, metadata), the same messages, the same frames
/// decoded, and every CRC valid (the crate's reader checks them all). The ground-truth
/// channels appear mid-run, inside a chunk, as they do when a log starts without them.
#[test]
fn our_container_writes_the_records_the_mcap_crate_writes() {
    let mut frames = Vec::new();
    // About 2.3 kB per frame: 1800 frames span four 1 MiB chunks.
    run(16, 3, &mut frames);
    assert!(frames.len() >= 1800, "{} frames", frames.len());
    for f in frames.iter_mut().take(700) {
        f.m.truth = None;
    }
    let meta = meta(&husky(), 3);
    let ours = encode_mcap_with(Container::Chunked, &meta, &frames, Path::new("ours")).unwrap();
    let theirs = encode_mcap_with(Container::Crate, &meta, &frames, Path::new("crate")).unwrap();

    let a = mcap::Summary::read(&ours)
        .unwrap()
        .expect("our file has a summary");
    let b = mcap::Summary::read(&theirs)
        .unwrap()
        .expect("the crate's file has a summary");
    assert_eq!(a.stats, b.stats);
    assert!(a.stats.as_ref().unwrap().chunk_count >= 4);
    let channels = |s: &mcap::Summary| {
        let mut v: Vec<_> = s
            .channels
            .values()
            .map(|c| {
                let schema = c.schema.as_ref().expect("every channel has a schema");
                (
                    c.id,
                    c.topic.clone(),
                    c.message_encoding.clone(),
                    c.metadata.clone(),
                    schema.name.clone(),
                    schema.encoding.clone(),
                    schema.data.to_vec(),
                )
            })
            .collect();
        v.sort();
        v
    };
    assert_eq!(channels(&a), channels(&b));
    assert_eq!(a.schemas.len(), b.schemas.len());
    let chunks = |s: &mcap::Summary| -> Vec<_> {
        s.chunk_indexes
            .iter()
            .map(|c| {
                (
                    c.message_start_time,
                    c.message_end_time,
                    c.uncompressed_size,
                    c.compression.clone(),
                    c.message_index_offsets.keys().copied().collect::<Vec<_>>(),
                )
            })
            .collect()
    };
    assert_eq!(chunks(&a), chunks(&b));
    let metadata =
        |s: &mcap::Summary| -> Vec<_> { s.metadata_indexes.iter().map(|m| m.name.clone()).collect() };
    assert_eq!(metadata(&a), metadata(&b));

    // The message indexes of each chunk point at the same messages.
    for (ca, cb) in a.chunk_indexes.iter().zip(&b.chunk_indexes) {
        let ia = a.read_message_indexes(&ours, ca).unwrap();
        let ib = b.read_message_indexes(&theirs, cb).unwrap();
        type Indexes<'a> = std::collections::HashMap<
            std::sync::Arc<mcap::Channel<'a>>,
            Vec<mcap::records::MessageIndexEntry>,
        >;
        let entries = |m: &Indexes| {
            let mut v: Vec<_> = m
                .iter()
                .map(|(c, e)| (c.id, e.iter().map(|x| x.log_time).collect::<Vec<_>>()))
                .collect();
            v.sort();
            v
        };
        assert_eq!(entries(&ia), entries(&ib));
        for (c, e) in &ia {
            for entry in e {
                let m = a.seek_message(&ours, ca, entry).unwrap();
                assert_eq!(m.channel.topic, c.topic);
                assert_eq!(m.log_time, entry.log_time);
            }
        }
    }

    let messages = |bytes: &[u8]| -> Vec<_> {
        mcap::MessageStream::new(bytes)
            .unwrap()
            .map(|m| {
                let m = m.unwrap();
                (
                    m.channel.topic.clone(),
                    m.sequence,
                    m.log_time,
                    m.publish_time,
                    m.data.to_vec(),
                )
            })
            .collect()
    };
    assert_eq!(messages(&ours), messages(&theirs));
    let (ma, fa) = decode_mcap(&ours, Path::new("ours")).unwrap();
    let (mb, fb) = decode_mcap(&theirs, Path::new("crate")).unwrap();
    assert_eq!((ma, fa), (mb, fb));

    // An empty log too: a header, the metadata, one chunk of schemas and channels, the summary.
    let ours = encode_mcap_with(Container::Chunked, &meta, &[], Path::new("ours")).unwrap();
    let theirs = encode_mcap_with(Container::Crate, &meta, &[], Path::new("crate")).unwrap();
    let a = mcap::Summary::read(&ours).unwrap().unwrap();
    let b = mcap::Summary::read(&theirs).unwrap().unwrap();
    assert_eq!(a.stats, b.stats);
    assert_eq!(channels(&a), channels(&b));
    // Our reader reads both alike (and refuses a log without messages, naming why).
    let message = |bytes: &[u8]| match decode_mcap(bytes, Path::new("log")) {
        Err(Error::Log { message, .. }) => message,
        other => panic!("an empty log must be refused: {other:?}"),
    };
    assert_eq!(message(&ours), message(&theirs));
}

#[test]
fn same_frames_give_byte_identical_files() {
    let mut frames = Vec::new();
    run(2, 11, &mut frames);
    let meta = meta(&husky(), 11);
    let a = encode_mcap(&meta, &frames, Path::new("a")).unwrap();
    let b = encode_mcap(&meta, &frames, Path::new("b")).unwrap();
    assert_eq!(a, b);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("c.mcap");
    write_mcap(&p, &meta, &frames).unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), a);
    // And a different run gives a different file.
    let mut other = Vec::new();
    run(2, 12, &mut other);
    assert_ne!(encode_mcap(&meta, &other, Path::new("d")).unwrap(), a);
}

/// `ros2 bag` reads the QoS to re-publish each topic with from the channel metadata, as rosbag2
/// itself writes it.
#[test]
fn every_channel_declares_its_offered_qos_as_rosbag2_does() {
    let mut frames = Vec::new();
    run(2, 5, &mut frames);
    let bytes = encode_mcap(&meta(&husky(), 5), &frames, Path::new("qos")).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert!(summary.channels.len() >= 7);
    for c in summary.channels.values() {
        let qos = c
            .metadata
            .get("offered_qos_profiles")
            .unwrap_or_else(|| panic!("{} has no offered_qos_profiles", c.topic));
        // One profile, rosbag2's integer form: reliable, volatile, infinite deadline.
        assert!(qos.starts_with("- history: "), "{}: {qos}", c.topic);
        assert_eq!(qos.matches("- history").count(), 1, "{}", c.topic);
        for line in ["  reliability: 1\n", "  durability: 2\n", "    sec: 9223372036\n"] {
            assert!(qos.contains(line), "{}: {line:?} not in {qos}", c.topic);
        }
    }
}

#[test]
fn unfinished_or_failed_logs_never_appear_at_the_final_path() {
    let dir = tempfile::tempdir().unwrap();
    let meta = meta(&husky(), 1);
    let mut frames = Vec::new();
    run(1, 1, &mut frames);

    // A complete log already at the path is kept, byte for byte, while a new run writes its
    // partial file, and after that run fails: a failed run loses nothing already written.
    let path = dir.path().join("run.mcap");
    write_mcap(&path, &meta, &frames).unwrap();
    let before = std::fs::read(&path).unwrap();
    let mut w = McapWriter::create(&path, &meta).unwrap();
    for f in &frames[..50] {
        w.write_frame(f).unwrap();
    }
    drop(w); // e.g. the simulation diverged and the caller returned early
    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert!(
        partial_path(&path).exists(),
        "the partial file stays for debugging"
    );
    std::fs::remove_file(&path).unwrap();

    // A bad frame fails the writer for good.
    let mut w = McapWriter::create(&path, &meta).unwrap();
    w.write_frame(&frames[0]).unwrap();
    let mut bad = frames[1];
    bad.m.enc.left_rad_s = f64::NAN;
    match w.write_frame(&bad) {
        Err(Error::Log {
            location, message, ..
        }) => {
            assert!(location.contains("frame 1"), "{location}");
            assert!(message.contains("enc"), "{message}");
        }
        r => panic!("NaN accepted: {r:?}"),
    }
    assert!(w.write_frame(&frames[1]).is_err());
    assert!(w.finish().is_err());
    assert!(!path.exists());

    // Stamps must increase strictly (the reader matches messages by time).
    let mut w = McapWriter::create(&path, &meta).unwrap();
    w.write_frame(&frames[1]).unwrap();
    let e = w.write_frame(&frames[0]).unwrap_err();
    assert!(e.to_string().contains("not after"), "{e}");
    let mut neg = frames[0];
    neg.stamp_s = -0.05;
    assert!(McapWriter::create(&path, &meta)
        .unwrap()
        .write_frame(&neg)
        .is_err());
    assert!(!path.exists());
}

/// A small valid log and its decoded frames.
fn small_log() -> (Vec<u8>, LogMeta, Vec<Frame>) {
    let mut frames = Vec::new();
    run(1, 2, &mut frames);
    let meta = meta(&husky(), 2);
    let bytes = encode_mcap(&meta, &frames, Path::new("small.mcap")).unwrap();
    let (_, decoded) = decode_mcap(&bytes, Path::new("small.mcap")).unwrap();
    (bytes, meta, decoded)
}

fn decode_no_panic(bytes: &[u8], what: &str) -> drive_sim::Result<(LogMeta, Vec<Frame>)> {
    std::panic::catch_unwind(|| decode_mcap(bytes, Path::new("x.mcap")))
        .unwrap_or_else(|_| panic!("reader panicked on {what}"))
}

#[test]
fn truncated_files_are_errors_not_panics() {
    let (bytes, _, _) = small_log();
    // ~500 cuts spread over the file, plus every cut in the header and the footer.
    let stride = bytes.len() / 500 + 1;
    let ends = (0..64).chain(bytes.len() - 64..bytes.len());
    for cut in (0..bytes.len()).step_by(stride).chain(ends) {
        match decode_no_panic(&bytes[..cut], &format!("truncation at {cut}")) {
            Err(Error::Log { .. }) => {}
            r => panic!(
                "truncation at {cut} of {}: {:?}",
                bytes.len(),
                r.map(|x| x.1.len())
            ),
        }
    }
}

#[test]
fn flipped_bytes_are_errors_or_leave_the_frames_intact() {
    let (bytes, _, frames) = small_log();
    let mut errors = 0;
    // ~700 flips spread over the file (an odd stride, so every byte lane of the records).
    let stride = (bytes.len() / 700) | 1;
    for at in (0..bytes.len()).step_by(stride) {
        let mut b = bytes.clone();
        b[at] ^= 0x5a;
        match decode_no_panic(&b, &format!("flip at {at}")) {
            Err(Error::Log { .. }) => errors += 1,
            Err(e) => panic!("flip at {at}: not a log error: {e}"),
            // Flips in the summary section or in index fields change nothing the reader uses;
            // the messages themselves are CRC-checked.
            Ok((_, got)) => assert_eq!(got, frames, "flip at {at} changed the frames silently"),
        }
    }
    // Every record is covered by a CRC (chunks, data section, summary): few flips go unseen.
    let tried = bytes.len().div_ceil(stride);
    assert!(errors * 10 > tried * 9, "{errors} errors out of {tried} flips");
    eprintln!("{} bytes: {errors} of {tried} flips detected", bytes.len());
}

/// Copies a valid log through the `mcap` crate, letting `edit` drop or change messages
/// (`None` drops), optionally without the metadata.
fn rewrite(
    bytes: &[u8],
    keep_meta: bool,
    mut edit: impl FnMut(&str, u64, &[u8]) -> Option<Vec<u8>>,
) -> Vec<u8> {
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .create(std::io::Cursor::new(Vec::new()))
        .unwrap();
    if keep_meta {
        let summary = mcap::Summary::read(bytes).unwrap().unwrap();
        for idx in &summary.metadata_indexes {
            w.write_metadata(&mcap::read::metadata(bytes, idx).unwrap())
                .unwrap();
        }
    }
    let mut counts: BTreeMap<String, u64> = BTreeMap::new();
    for m in mcap::MessageStream::new(bytes).unwrap() {
        let m = m.unwrap();
        let c = counts.entry(m.channel.topic.clone()).or_insert(0);
        if let Some(data) = edit(&m.channel.topic, *c, &m.data) {
            w.write(&mcap::Message {
                data: data.into(),
                ..m
            })
            .unwrap();
        }
        *c += 1;
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}

fn log_error(r: drive_sim::Result<(LogMeta, Vec<Frame>)>) -> (String, String) {
    match r {
        Err(Error::Log {
            location, message, ..
        }) => (location, message),
        Err(e) => panic!("not a log error: {e}"),
        Ok(_) => panic!("damaged log accepted"),
    }
}

#[test]
fn identity_rewrite_is_accepted() {
    let (bytes, meta, frames) = small_log();
    let copy = rewrite(&bytes, true, |_, _, d| Some(d.to_vec()));
    let (m, f) = decode_mcap(&copy, Path::new("copy.mcap")).unwrap();
    assert_eq!((m, f), (meta, frames));
}

#[test]
fn missing_metadata_topic_or_message_and_undecodable_messages_are_located() {
    let (bytes, _, _) = small_log();
    let p = Path::new("edited.mcap");

    let (loc, msg) = log_error(decode_mcap(
        &rewrite(&bytes, false, |_, _, d| Some(d.to_vec())),
        p,
    ));
    assert!(
        loc.contains("metadata") && msg.contains("drive_sim"),
        "{loc}: {msg}"
    );

    let no_imu = rewrite(&bytes, true, |t, _, d| (t != TOPIC_IMU).then(|| d.to_vec()));
    let (loc, _) = log_error(decode_mcap(&no_imu, p));
    assert!(loc.contains(TOPIC_IMU), "{loc}");

    let no_markers = rewrite(&bytes, true, |t, _, d| (t != TOPIC_MARKER).then(|| d.to_vec()));
    let (loc, _) = log_error(decode_mcap(&no_markers, p));
    assert!(loc.contains(TOPIC_MARKER), "{loc}");

    // One ground-truth message missing out of a pair.
    let half_truth = rewrite(&bytes, true, |t, i, d| {
        (!(t == TOPIC_TRUTH_JOINTS && i == 7)).then(|| d.to_vec())
    });
    let (loc, _) = log_error(decode_mcap(&half_truth, p));
    assert!(loc.contains(TOPIC_TRUTH_JOINTS), "{loc}");

    // A truncated payload: the error names the topic, the message index and the field.
    let cut = rewrite(&bytes, true, |t, i, d| {
        Some(if t == TOPIC_ICP_ODOM && i == 5 {
            d[..100].to_vec()
        } else {
            d.to_vec()
        })
    });
    let (loc, msg) = log_error(decode_mcap(&cut, p));
    assert!(loc.contains("topic /icp_odom message 5"), "{loc}");
    assert!(msg.contains("pose"), "{msg}");

    // A non-unit quaternion.
    let skew = rewrite(&bytes, true, |t, i, d| {
        let mut d = d.to_vec();
        if t == TOPIC_ICP_ODOM && i == 9 {
            // orientation.w is the 7th float64 of the pose, which starts at 40: header ends
            // at 17, child_frame_id's length at 20..24, "base_link\0" at 24..34, pad to 40.
            let at = 4 + 40 + 6 * 8;
            d[at..at + 8].copy_from_slice(&3.0f64.to_le_bytes());
        }
        Some(d)
    });
    let (loc, msg) = log_error(decode_mcap(&skew, p));
    assert!(loc.contains("topic /icp_odom message 9"), "{loc}");
    assert!(msg.contains("quaternion"), "{msg}");
}
