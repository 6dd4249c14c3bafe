//! ROS 2 MCAP writer and reader for DRIVE logs.
//!
//! [`McapWriter`] streams [`Frame`]s into an MCAP file that Foxglove, `ros2 bag` (with the MCAP
//! storage plugin) and the official `mcap` readers decode as ROS 2 messages: profile `ros2`,
//! schemas `ros2msg` with every dependency embedded as rosbag2 writes them, messages in CDR.
//! [`read_mcap`] decodes such a file back into the same [`DriveLog`] the in-memory frames give.
//!
//! # Topics
//! One message per topic per frame (20 Hz in the DRIVE protocol), all stamped with the frame's
//! time:
//!
//! | topic | type | content |
//! |---|---|---|
//! | `/drive/marker` | `drive_sim_msgs/msg/DriveMarker` | protocol phase (`step`/`reorient`/`idle`), step, attempt, window, k, time in step, exact log time |
//! | `/cmd_vel` | `geometry_msgs/msg/TwistStamped` | body command: the wheel command through the declared IDD ([`Nominal::idd`](super::Nominal::idd)), frame `base_link` |
//! | `/wheel_cmd` | `sensor_msgs/msg/JointState` | commanded wheel speeds, `velocity` in rad/s for joints `left_wheel`, `right_wheel` |
//! | `/joint_states` | `sensor_msgs/msg/JointState` | encoder wheel speeds, same joints (no position or effort) |
//! | `/icp_odom` | `nav_msgs/msg/Odometry` | lidar/ICP pose, frame `odom`, child `base_link`; twist = the source's own body-velocity estimate, or NaN with `twist.covariance[0] = -1` when it has none |
//! | `/imu/data_raw` | `sensor_msgs/msg/Imu` | yaw rate and specific force in `base_link`; no orientation (`orientation_covariance[0] = -1`), other covariances 0 (unknown) |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | `odom`→`base_link` from the lidar pose, and `odom`→`base_link_truth` from the ground truth when there is one |
//! | `/ground_truth/odom` | `nav_msgs/msg/Odometry` | simulated logs only: true pose in `odom`, true twist in the body frame (child `base_link`) |
//! | `/ground_truth/joint_states` | `sensor_msgs/msg/JointState` | simulated logs only: true wheel speeds |
//!
//! The [`LogMeta`] is an MCAP metadata record named [`METADATA_NAME`] with keys `format`
//! ([`FORMAT`]) and `log_meta` (JSON).
//!
//! # Time
//! `log_time`, `publish_time` and header stamps are `1 s + stamp_s`, in ns: fixed, never wall
//! clock, and never 0 (tf treats a zero stamp as "latest"). The marker also carries `stamp_s`
//! exactly as an f64, so reading gives back the very same stamps. Frame stamps must increase
//! strictly: the reader matches the messages of one frame by their log time.
//!
//! # Exactness
//! Every value read back is bit-identical to the value written, except roll, pitch and yaw:
//! ROS carries attitude as a quaternion, and Euler → quaternion → Euler is exact only to about
//! 1e-15 rad (yaw ±π may come back as ∓π).
//!
//! # File
//! Chunked (1 MiB chunks), zstd-compressed (the `mcap` crate's default codec; Foxglove, the Go
//! CLI and the Python `mcap` package all read it, the latter through its `zstandard`
//! dependency), with chunk and message indexes and a summary, so readers can seek. Output is a
//! deterministic function of the frames: no clock, no hash ordering, single-threaded zstd.
//! The writer writes `<path>.partial` and renames it to `<path>` only in
//! [`McapWriter::finish`]: a crashed or failed run leaves no complete-looking log behind.

use super::cdr::CdrError;
use super::ros_msgs::{
    DriveMarker, Header, Imu, JointState, Odometry, Pose as RosPose, Quaternion, RosMessage, TfMessage, Time,
    TransformStamped, Twist, TwistStamped, Vector3,
};
use super::{DriveLog, Frame, GroundTruth, ImuReading, LogMeta, Measurement, Phase, Pose};
use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use crate::protocol::FrameSink;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Cursor, Seek, Write};
use std::path::{Path, PathBuf};

/// Protocol phase marker topic.
pub const TOPIC_MARKER: &str = "/drive/marker";
/// Body command topic.
pub const TOPIC_CMD_VEL: &str = "/cmd_vel";
/// Wheel command topic.
pub const TOPIC_WHEEL_CMD: &str = "/wheel_cmd";
/// Encoder topic.
pub const TOPIC_JOINT_STATES: &str = "/joint_states";
/// Lidar/ICP odometry topic.
pub const TOPIC_ICP_ODOM: &str = "/icp_odom";
/// IMU topic.
pub const TOPIC_IMU: &str = "/imu/data_raw";
/// Transform tree topic.
pub const TOPIC_TF: &str = "/tf";
/// Ground-truth odometry topic (simulated logs).
pub const TOPIC_TRUTH_ODOM: &str = "/ground_truth/odom";
/// Ground-truth wheel speed topic (simulated logs).
pub const TOPIC_TRUTH_JOINTS: &str = "/ground_truth/joint_states";

/// Name of the metadata record holding the [`LogMeta`].
pub const METADATA_NAME: &str = "drive_sim";
/// Value of the metadata `format` key; bumped when the topic layout changes.
pub const FORMAT: &str = "drive-sim-mcap/1";
/// Offset added to `stamp_s` in every MCAP and header time, ns.
pub const EPOCH_OFFSET_NS: u64 = 1_000_000_000;

/// Fixed frame of poses.
pub const FRAME_ODOM: &str = "odom";
/// Body frame.
pub const FRAME_BASE: &str = "base_link";
/// Body frame of the ground truth in `/tf`.
pub const FRAME_BASE_TRUTH: &str = "base_link_truth";
/// Joint name of the left wheels.
pub const JOINT_LEFT: &str = "left_wheel";
/// Joint name of the right wheels.
pub const JOINT_RIGHT: &str = "right_wheel";

/// Uncompressed chunk size: about 450 frames of 2.3 kB, a good zstd window, still small enough
/// that Foxglove seeks quickly.
const CHUNK_SIZE: u64 = 1 << 20;

/// What [`McapWriter::finish`] reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct McapSummary {
    /// The finished log.
    pub path: PathBuf,
    /// Frames written.
    pub frames: u64,
    /// Messages per topic (every topic of the file, in name order).
    pub messages_per_topic: BTreeMap<String, u64>,
    /// File size, bytes.
    pub bytes: u64,
}

/// Channel ids of the topics written for every frame.
#[derive(Debug, Clone, Copy)]
struct Channels {
    marker: u16,
    cmd_vel: u16,
    wheel_cmd: u16,
    joint_states: u16,
    icp_odom: u16,
    imu: u16,
    tf: u16,
}

/// Turns frames into MCAP messages on any seekable sink.
struct FrameEncoder<W: Write + Seek> {
    w: mcap::Writer<W>,
    ch: Channels,
    /// (odom, joint states), added at the first frame with ground truth.
    truth_ch: Option<(u16, u16)>,
    idd: IdealDiffDrive,
    /// Messages per channel id (also the next sequence number).
    counts: BTreeMap<u16, u32>,
    topics: BTreeMap<u16, &'static str>,
    last_ns: Option<u64>,
    frames: u64,
    buf: Vec<u8>,
    /// Names the log in errors.
    file: PathBuf,
}

fn mcap_err(file: &Path, location: &str, e: mcap::McapError) -> Error {
    Error::log(file, location, format!("MCAP: {e}"))
}

impl<W: Write + Seek> FrameEncoder<W> {
    fn new(sink: W, meta: &LogMeta, file: &Path) -> Result<Self> {
        let opts = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("drive-sim {}", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .compression_level(1)
            .compression_threads(0)
            .chunk_size(Some(CHUNK_SIZE));
        let e = |e| mcap_err(file, "header", e);
        let mut w = opts.create(sink).map_err(e)?;
        let json = serde_json::to_string(meta)
            .map_err(|x| Error::log(file, "metadata", format!("cannot serialize: {x}")))?;
        w.write_metadata(&mcap::records::Metadata {
            name: METADATA_NAME.into(),
            metadata: BTreeMap::from([
                ("format".to_string(), FORMAT.to_string()),
                ("log_meta".to_string(), json),
            ]),
        })
        .map_err(e)?;
        let mut topics = BTreeMap::new();
        let mut add = |w: &mut mcap::Writer<W>, topic: &'static str, def| -> Result<u16> {
            let id = add_channel(w, topic, def).map_err(e)?;
            topics.insert(id, topic);
            Ok(id)
        };
        let ch = Channels {
            marker: add(&mut w, TOPIC_MARKER, DriveMarker::DEF)?,
            cmd_vel: add(&mut w, TOPIC_CMD_VEL, TwistStamped::DEF)?,
            wheel_cmd: add(&mut w, TOPIC_WHEEL_CMD, JointState::DEF)?,
            joint_states: add(&mut w, TOPIC_JOINT_STATES, JointState::DEF)?,
            icp_odom: add(&mut w, TOPIC_ICP_ODOM, Odometry::DEF)?,
            imu: add(&mut w, TOPIC_IMU, Imu::DEF)?,
            tf: add(&mut w, TOPIC_TF, TfMessage::DEF)?,
        };
        Ok(Self {
            w,
            ch,
            truth_ch: None,
            idd: meta.nominal.idd(),
            counts: BTreeMap::new(),
            topics,
            last_ns: None,
            frames: 0,
            buf: Vec::with_capacity(1024),
            file: file.to_path_buf(),
        })
    }

    fn put<M: RosMessage>(&mut self, channel: u16, ns: u64, msg: &M) -> Result<()> {
        let data = msg.to_cdr(std::mem::take(&mut self.buf));
        let n = self.counts.entry(channel).or_insert(0);
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: *n,
            log_time: ns,
            publish_time: ns,
        };
        *n += 1;
        let r = self.w.write_to_known_channel(&header, &data);
        self.buf = data;
        r.map_err(|e| {
            mcap_err(
                &self.file,
                &format!("frame {} topic {}", self.frames, self.topics[&channel]),
                e,
            )
        })
    }

    fn write_frame(&mut self, f: &Frame) -> Result<()> {
        let loc = format!("frame {} (t = {} s)", self.frames, f.stamp_s);
        check_frame(f).map_err(|m| Error::log(&self.file, &loc, m))?;
        let ns = stamp_to_ns(f.stamp_s).map_err(|m| Error::log(&self.file, &loc, m))?;
        if let Some(prev) = self.last_ns {
            if ns <= prev {
                return Err(Error::log(
                    &self.file,
                    &loc,
                    format!(
                        "stamp is not after the previous frame's ({} ns <= {} ns); \
                         MCAP frames must have strictly increasing stamps",
                        ns - EPOCH_OFFSET_NS,
                        prev - EPOCH_OFFSET_NS
                    ),
                ));
            }
        }
        let stamp = Time::from_ns(ns).ok_or_else(|| Error::log(&self.file, &loc, "stamp beyond 2038"))?;
        let header = |frame_id: &str| Header {
            stamp,
            frame_id: frame_id.to_string(),
        };
        let m = &f.m;

        let ch = self.ch;
        self.put(ch.marker, ns, &marker_msg(header(""), f))?;
        let body = self.idd.body_from_wheels(m.cmd);
        self.put(
            ch.cmd_vel,
            ns,
            &TwistStamped {
                header: header(FRAME_BASE),
                twist: body_twist(body),
            },
        )?;
        self.put(ch.wheel_cmd, ns, &wheels_msg(header(""), m.cmd))?;
        self.put(ch.joint_states, ns, &wheels_msg(header(""), m.enc))?;
        let (twist, twist_covariance) = match m.reference {
            Some(v) => (body_twist(v), [0.0; 36]),
            None => {
                let nan = Vector3 {
                    x: f64::NAN,
                    y: f64::NAN,
                    z: 0.0,
                };
                let mut cov = [0.0; 36];
                cov[0] = -1.0;
                (
                    Twist {
                        linear: nan,
                        angular: Vector3 {
                            x: 0.0,
                            y: 0.0,
                            z: f64::NAN,
                        },
                    },
                    cov,
                )
            }
        };
        self.put(
            ch.icp_odom,
            ns,
            &Odometry {
                header: header(FRAME_ODOM),
                child_frame_id: FRAME_BASE.into(),
                pose: ros_pose(m.pose),
                pose_covariance: [0.0; 36],
                twist,
                twist_covariance,
            },
        )?;
        let mut orientation_covariance = [0.0; 9];
        orientation_covariance[0] = -1.0;
        self.put(
            ch.imu,
            ns,
            &Imu {
                header: header(FRAME_BASE),
                orientation: Quaternion::default(),
                orientation_covariance,
                angular_velocity: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: m.imu.wz_rad_s,
                },
                angular_velocity_covariance: [0.0; 9],
                linear_acceleration: Vector3 {
                    x: m.imu.ax_m_s2,
                    y: m.imu.ay_m_s2,
                    z: m.imu.az_m_s2,
                },
                linear_acceleration_covariance: [0.0; 9],
            },
        )?;
        let transform = |child: &str, p: Pose| {
            let rp = ros_pose(p);
            TransformStamped {
                header: header(FRAME_ODOM),
                child_frame_id: child.into(),
                translation: rp.position,
                rotation: rp.orientation,
            }
        };
        let mut transforms = vec![transform(FRAME_BASE, m.pose)];
        if let Some(t) = m.truth {
            transforms.push(transform(FRAME_BASE_TRUTH, t.pose));
        }
        self.put(ch.tf, ns, &TfMessage { transforms })?;
        if let Some(t) = m.truth {
            let (odom, joints) = match self.truth_ch {
                Some(c) => c,
                None => {
                    let e = |e| mcap_err(&self.file, &loc, e);
                    let o = add_channel(&mut self.w, TOPIC_TRUTH_ODOM, Odometry::DEF).map_err(e)?;
                    let j = add_channel(&mut self.w, TOPIC_TRUTH_JOINTS, JointState::DEF).map_err(e)?;
                    self.topics.insert(o, TOPIC_TRUTH_ODOM);
                    self.topics.insert(j, TOPIC_TRUTH_JOINTS);
                    self.truth_ch = Some((o, j));
                    (o, j)
                }
            };
            self.put(
                odom,
                ns,
                &Odometry {
                    header: header(FRAME_ODOM),
                    child_frame_id: FRAME_BASE.into(),
                    pose: ros_pose(t.pose),
                    pose_covariance: [0.0; 36],
                    twist: body_twist(t.velocity),
                    twist_covariance: [0.0; 36],
                },
            )?;
            self.put(joints, ns, &wheels_msg(header(""), t.wheels))?;
        }
        self.last_ns = Some(ns);
        self.frames += 1;
        Ok(())
    }

    /// Writes the summary; returns the sink and the per-topic counts.
    fn finish(mut self) -> Result<(W, u64, BTreeMap<String, u64>)> {
        self.w.finish().map_err(|e| mcap_err(&self.file, "summary", e))?;
        let counts = self
            .topics
            .iter()
            .map(|(id, t)| (t.to_string(), self.counts.get(id).copied().unwrap_or(0) as u64))
            .collect();
        Ok((self.w.into_inner(), self.frames, counts))
    }
}

fn add_channel<W: Write + Seek>(
    w: &mut mcap::Writer<W>,
    topic: &str,
    def: &'static super::ros_msgs::MsgDef,
) -> mcap::McapResult<u16> {
    let schema = w.add_schema(&def.schema_name(), "ros2msg", def.schema_text().as_bytes())?;
    w.add_channel(schema, topic, "cdr", &BTreeMap::new())
}

/// Log time of a frame stamp, ns, with the fixed epoch offset.
fn stamp_to_ns(stamp_s: f64) -> std::result::Result<u64, String> {
    // Upper bound keeps the header's int32 seconds valid.
    if !(stamp_s.is_finite() && (0.0..2.0e9).contains(&stamp_s)) {
        return Err(format!("stamp {stamp_s} s is not in [0, 2e9) s"));
    }
    Ok((stamp_s * 1e9).round() as u64 + EPOCH_OFFSET_NS)
}

/// Refuses frames that the reader would refuse: non-finite values, NaN in optional parts.
fn check_frame(f: &Frame) -> std::result::Result<(), String> {
    let m = &f.m;
    let mut bad = Vec::new();
    if !m.cmd.is_finite() {
        bad.push("cmd");
    }
    if !m.enc.is_finite() {
        bad.push("enc");
    }
    if !m.pose.is_finite() {
        bad.push("pose");
    }
    let i = m.imu;
    if ![i.wz_rad_s, i.ax_m_s2, i.ay_m_s2, i.az_m_s2]
        .iter()
        .all(|v| v.is_finite())
    {
        bad.push("imu");
    }
    if m.reference.is_some_and(|r| !r.is_finite()) {
        bad.push("reference");
    }
    if let Some(t) = m.truth {
        if !(t.pose.is_finite() && t.velocity.is_finite() && t.wheels.is_finite()) {
            bad.push("truth");
        }
    }
    if let Phase::Step { t_in_step_s, .. } = f.phase {
        if !t_in_step_s.is_finite() {
            bad.push("phase.t_in_step_s");
        }
    }
    if bad.is_empty() {
        Ok(())
    } else {
        Err(format!("non-finite values in {}", bad.join(", ")))
    }
}

fn marker_msg(header: Header, f: &Frame) -> DriveMarker {
    let mut m = DriveMarker {
        header,
        stamp: f.stamp_s,
        ..Default::default()
    };
    match f.phase {
        Phase::Step {
            step,
            attempt,
            window,
            k,
            t_in_step_s,
        } => {
            m.phase = "step".into();
            m.step = step;
            m.attempt = attempt;
            m.window = window;
            m.k = k;
            m.t_in_step = t_in_step_s;
        }
        Phase::Reorient { step } => {
            m.phase = "reorient".into();
            m.step = step;
        }
        Phase::Idle => m.phase = "idle".into(),
    }
    m
}

fn body_twist(v: BodyVelocity) -> Twist {
    Twist {
        linear: Vector3 {
            x: v.vx_m_s,
            y: v.vy_m_s,
            z: 0.0,
        },
        angular: Vector3 {
            x: 0.0,
            y: 0.0,
            z: v.wz_rad_s,
        },
    }
}

fn wheels_msg(header: Header, w: WheelSpeeds) -> JointState {
    JointState {
        header,
        name: vec![JOINT_LEFT.into(), JOINT_RIGHT.into()],
        position: Vec::new(),
        velocity: vec![w.left_rad_s, w.right_rad_s],
        effort: Vec::new(),
    }
}

fn ros_pose(p: Pose) -> RosPose {
    // ZYX (yaw, then pitch, then roll): nalgebra's from_euler_angles(roll, pitch, yaw).
    let q = nalgebra::UnitQuaternion::from_euler_angles(p.roll_rad, p.pitch_rad, p.yaw_rad);
    RosPose {
        position: Vector3 {
            x: p.x_m,
            y: p.y_m,
            z: p.z_m,
        },
        orientation: Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    }
}

/// Streams frames into a ROS 2 MCAP file (see the [module docs](self) for the layout).
///
/// Writes `<path>.partial`; only [`finish`](Self::finish) renames it to `path`. Dropping the
/// writer without finishing, or any error, leaves `path` absent and the partial file for
/// debugging. After an error every further call fails.
pub struct McapWriter {
    enc: Option<FrameEncoder<BufWriter<File>>>,
    path: PathBuf,
    partial: PathBuf,
    failed: Option<String>,
}

impl std::fmt::Debug for McapWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapWriter")
            .field("path", &self.path)
            .field("partial", &self.partial)
            .field("frames", &self.enc.as_ref().map(|e| e.frames))
            .field("failed", &self.failed)
            .finish()
    }
}

/// `<path>.partial`.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".partial");
    PathBuf::from(s)
}

impl McapWriter {
    /// Starts a log at `path` (removing any file already there, as a new log replaces it) and
    /// writes the metadata.
    pub fn create(path: impl AsRef<Path>, meta: &LogMeta) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let partial = partial_path(&path);
        // An existing log at `path` stays untouched until `finish` atomically renames the new
        // one over it: a failed run loses nothing that was already written.
        let file = File::create(&partial).map_err(|e| Error::io(&partial, e))?;
        let enc = FrameEncoder::new(BufWriter::with_capacity(1 << 16, file), meta, &partial)?;
        Ok(Self {
            enc: Some(enc),
            path,
            partial,
            failed: None,
        })
    }

    /// The file being written until [`finish`](Self::finish).
    pub fn partial_path(&self) -> &Path {
        &self.partial
    }

    /// Frames written so far.
    pub fn frames(&self) -> u64 {
        self.enc.as_ref().map_or(0, |e| e.frames)
    }

    fn encoder(&mut self) -> Result<&mut FrameEncoder<BufWriter<File>>> {
        if let Some(m) = &self.failed {
            return Err(Error::log(
                &self.partial,
                "writer",
                format!("an earlier write failed ({m}); the log is incomplete"),
            ));
        }
        self.enc
            .as_mut()
            .ok_or_else(|| Error::log(&self.partial, "writer", "already finished"))
    }

    /// Appends one frame. Its stamp must be after the previous frame's and its values finite.
    pub fn write_frame(&mut self, frame: &Frame) -> Result<()> {
        let r = self.encoder()?.write_frame(frame);
        if let Err(e) = &r {
            self.failed = Some(e.to_string());
        }
        r
    }

    /// Writes the summary, syncs the file and renames it to its final path.
    pub fn finish(mut self) -> Result<McapSummary> {
        self.encoder()?;
        let enc = self
            .enc
            .take()
            .ok_or_else(|| Error::log(&self.partial, "writer", "already finished"))?;
        let (buf, frames, messages_per_topic) = enc.finish()?;
        let file = buf
            .into_inner()
            .map_err(|e| Error::io(&self.partial, e.into_error()))?;
        file.sync_all().map_err(|e| Error::io(&self.partial, e))?;
        let bytes = file.metadata().map_err(|e| Error::io(&self.partial, e))?.len();
        drop(file);
        std::fs::rename(&self.partial, &self.path).map_err(|e| Error::io(&self.path, e))?;
        Ok(McapSummary {
            path: self.path.clone(),
            frames,
            messages_per_topic,
            bytes,
        })
    }
}

impl FrameSink for McapWriter {
    fn frame(&mut self, frame: &Frame) -> Result<()> {
        self.write_frame(frame)
    }
}

/// Writes `frames` to `path` in one go.
pub fn write_mcap(path: impl AsRef<Path>, meta: &LogMeta, frames: &[Frame]) -> Result<McapSummary> {
    let mut w = McapWriter::create(path, meta)?;
    for f in frames {
        w.write_frame(f)?;
    }
    w.finish()
}

/// Encodes `frames` into an in-memory MCAP file (same bytes as [`write_mcap`] writes).
/// `file` only names the log in errors.
pub fn encode_mcap(meta: &LogMeta, frames: &[Frame], file: &Path) -> Result<Vec<u8>> {
    let mut enc = FrameEncoder::new(Cursor::new(Vec::new()), meta, file)?;
    for f in frames {
        enc.write_frame(f)?;
    }
    Ok(enc.finish()?.0.into_inner())
}

/// Reads a drive-sim MCAP log into the common [`DriveLog`].
pub fn read_mcap(path: impl AsRef<Path>) -> Result<DriveLog> {
    let (meta, frames) = read_mcap_frames(path)?;
    Ok(DriveLog::from_frames(meta, &frames))
}

/// Reads a drive-sim MCAP log into its metadata and frames.
pub fn read_mcap_frames(path: impl AsRef<Path>) -> Result<(LogMeta, Vec<Frame>)> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_mcap(&bytes, path)
}

/// Messages of one topic, by log time; the value keeps the message index for errors.
type ByTime<T> = BTreeMap<u64, (u64, T)>;

#[derive(Default)]
struct Decoded {
    marker: ByTime<DriveMarker>,
    wheel_cmd: ByTime<JointState>,
    joint_states: ByTime<JointState>,
    icp_odom: ByTime<Odometry>,
    imu: ByTime<Imu>,
    truth_odom: ByTime<Odometry>,
    truth_joints: ByTime<JointState>,
}

/// The topics the reader needs and their types; `/cmd_vel` and `/tf` are derived and ignored,
/// like any other topic a user may have added.
const READ_TOPICS: [(&str, &super::ros_msgs::MsgDef); 7] = [
    (TOPIC_MARKER, &super::ros_msgs::DRIVE_MARKER),
    (TOPIC_WHEEL_CMD, &super::ros_msgs::JOINT_STATE),
    (TOPIC_JOINT_STATES, &super::ros_msgs::JOINT_STATE),
    (TOPIC_ICP_ODOM, &super::ros_msgs::ODOMETRY),
    (TOPIC_IMU, &super::ros_msgs::IMU),
    (TOPIC_TRUTH_ODOM, &super::ros_msgs::ODOMETRY),
    (TOPIC_TRUTH_JOINTS, &super::ros_msgs::JOINT_STATE),
];

/// Longest record (or decompressed chunk) the reader accepts, bytes: drive-sim writes 1 MiB
/// chunks and sub-kB messages, other tools use chunks of a few MiB; a corrupted length must not
/// make the reader allocate more than this.
const RECORD_LENGTH_LIMIT: usize = 64 << 20;

/// Every record of an MCAP file in order, chunks unpacked, with every CRC checked.
///
/// The `mcap` crate's `ChunkFlattener` does the same without a record length limit, so a
/// flipped bit in a chunk header makes it allocate exabytes and abort; this drives the crate's
/// sans-IO reader with the limit set.
struct Records<'a> {
    buf: &'a [u8],
    reader: mcap::sans_io::LinearReader,
}

impl<'a> Records<'a> {
    fn new(buf: &'a [u8]) -> Self {
        let opts = mcap::sans_io::LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_prevalidate_chunk_crcs(true)
            .with_validate_data_section_crc(true)
            .with_validate_summary_section_crc(true)
            .with_record_length_limit(RECORD_LENGTH_LIMIT);
        Self {
            buf,
            reader: mcap::sans_io::LinearReader::new_with_options(opts),
        }
    }
}

impl Iterator for Records<'_> {
    type Item = mcap::McapResult<mcap::records::Record<'static>>;

    fn next(&mut self) -> Option<Self::Item> {
        use mcap::sans_io::LinearReadEvent;
        while let Some(event) = self.reader.next_event() {
            match event {
                Ok(LinearReadEvent::ReadRequest(need)) => {
                    let len = need.min(self.buf.len());
                    self.reader.insert(len).copy_from_slice(&self.buf[..len]);
                    self.reader.notify_read(len);
                    self.buf = &self.buf[len..];
                }
                Ok(LinearReadEvent::Record { data, opcode }) => {
                    return Some(mcap::read::parse_record(opcode, data).map(|r| r.into_owned()))
                }
                Err(e) => return Some(Err(e)),
            }
        }
        None
    }
}

/// Decodes an in-memory drive-sim MCAP log; `file` names it in errors.
pub fn decode_mcap(bytes: &[u8], file: &Path) -> Result<(LogMeta, Vec<Frame>)> {
    use mcap::records::Record;
    let reader = Records::new(bytes);
    // schema id -> (name, encoding)
    let mut schemas: BTreeMap<u16, (String, String)> = BTreeMap::new();
    // channel id -> index in READ_TOPICS, or None for topics the reader ignores
    let mut channels: BTreeMap<u16, Option<usize>> = BTreeMap::new();
    let mut per_topic = [0u64; READ_TOPICS.len()];
    let mut meta: Option<LogMeta> = None;
    let mut d = Decoded::default();
    let mut profile_seen = false;
    let mut messages = 0u64;
    for (i, rec) in reader.enumerate() {
        let rec =
            rec.map_err(|e| mcap_err(file, &format!("MCAP record {i} (after {messages} messages)"), e))?;
        match rec {
            Record::Header(h) => {
                if h.profile != "ros2" {
                    return Err(Error::log(
                        file,
                        "header",
                        format!("profile `{}`, expected `ros2`", h.profile),
                    ));
                }
                profile_seen = true;
            }
            Record::Schema { header, .. } => {
                schemas.insert(header.id, (header.name, header.encoding));
            }
            Record::Channel(c) => {
                let known = READ_TOPICS.iter().position(|(t, _)| *t == c.topic);
                if let Some(k) = known {
                    let def = READ_TOPICS[k].1;
                    let (name, enc) = schemas.get(&c.schema_id).cloned().unwrap_or_default();
                    if name != def.schema_name() || enc != "ros2msg" || c.message_encoding != "cdr" {
                        return Err(Error::log(
                            file,
                            format!("topic {}", c.topic),
                            format!(
                                "type `{name}` ({enc}, {}), expected `{}` (ros2msg, cdr)",
                                c.message_encoding,
                                def.schema_name()
                            ),
                        ));
                    }
                }
                channels.insert(c.id, known);
            }
            Record::Metadata(m) if m.name == METADATA_NAME => {
                meta = Some(parse_meta(&m.metadata, file)?);
            }
            Record::Message { header, data } => {
                messages += 1;
                let Some(known) = channels.get(&header.channel_id) else {
                    return Err(Error::log(
                        file,
                        format!("message {messages}"),
                        format!("on unknown channel {}", header.channel_id),
                    ));
                };
                let Some(k) = *known else { continue };
                let idx = per_topic[k];
                per_topic[k] += 1;
                let topic = READ_TOPICS[k].0;
                let t = header.log_time;
                let loc = || msg_loc(topic, idx, t);
                let de = |e: CdrError| Error::log(file, loc(), format!("does not decode: {e}"));
                let dup = || Error::log(file, loc(), "a second message at the same log time");
                macro_rules! store {
                    ($map:expr, $ty:ty) => {{
                        let m = <$ty>::from_cdr(&data).map_err(de)?;
                        if $map.insert(t, (idx, m)).is_some() {
                            return Err(dup());
                        }
                    }};
                }
                match topic {
                    TOPIC_MARKER => store!(d.marker, DriveMarker),
                    TOPIC_WHEEL_CMD => store!(d.wheel_cmd, JointState),
                    TOPIC_JOINT_STATES => store!(d.joint_states, JointState),
                    TOPIC_ICP_ODOM => store!(d.icp_odom, Odometry),
                    TOPIC_IMU => store!(d.imu, Imu),
                    TOPIC_TRUTH_ODOM => store!(d.truth_odom, Odometry),
                    _ => store!(d.truth_joints, JointState),
                }
            }
            _ => {}
        }
    }
    if !profile_seen {
        return Err(Error::log(file, "header", "no MCAP header record"));
    }
    let meta = meta.ok_or_else(|| {
        Error::log(
            file,
            "metadata",
            format!("no `{METADATA_NAME}` metadata record: not a drive-sim log"),
        )
    })?;
    let frames = assemble(&d, file)?;
    Ok((meta, frames))
}

fn msg_loc(topic: &str, idx: u64, log_time_ns: u64) -> String {
    format!(
        "topic {topic} message {idx} (log time {:.3} s)",
        log_time_ns as f64 * 1e-9
    )
}

fn parse_meta(m: &BTreeMap<String, String>, file: &Path) -> Result<LogMeta> {
    let loc = format!("metadata `{METADATA_NAME}`");
    match m.get("format") {
        Some(f) if f == FORMAT => {}
        Some(f) => {
            return Err(Error::log(
                file,
                &loc,
                format!("format `{f}`, this reader reads `{FORMAT}`"),
            ))
        }
        None => return Err(Error::log(file, &loc, "no `format` key")),
    }
    let json = m
        .get("log_meta")
        .ok_or_else(|| Error::log(file, &loc, "no `log_meta` key"))?;
    let de = &mut serde_json::Deserializer::from_str(json);
    let meta: LogMeta = serde_path_to_error::deserialize(de).map_err(|e| {
        Error::log(
            file,
            format!("{loc} key `log_meta` at `{}`", e.path()),
            e.inner().to_string(),
        )
    })?;
    if !(meta.rate_hz.is_finite() && meta.rate_hz > 0.0) {
        return Err(Error::log(
            file,
            format!("{loc} key `log_meta` at `rate_hz`"),
            format!("{} is not a positive rate", meta.rate_hz),
        ));
    }
    Ok(meta)
}

/// Matches each marker with the messages of the same log time and rebuilds the frames.
fn assemble(d: &Decoded, file: &Path) -> Result<Vec<Frame>> {
    if d.marker.is_empty() {
        return Err(Error::log(
            file,
            format!("topic {TOPIC_MARKER}"),
            "no messages: not a drive-sim log, or an empty one",
        ));
    }
    let mut frames = Vec::with_capacity(d.marker.len());
    for (&t, (idx, mk)) in &d.marker {
        let loc = msg_loc(TOPIC_MARKER, *idx, t);
        let cmd = at(&d.wheel_cmd, t, TOPIC_WHEEL_CMD, &loc, file)?;
        let enc = at(&d.joint_states, t, TOPIC_JOINT_STATES, &loc, file)?;
        let icp = at(&d.icp_odom, t, TOPIC_ICP_ODOM, &loc, file)?;
        let imu = at(&d.imu, t, TOPIC_IMU, &loc, file)?;
        let truth = match (d.truth_odom.get(&t), d.truth_joints.get(&t)) {
            (None, None) => None,
            (Some(o), Some(j)) => Some(GroundTruth {
                pose: pose_of(&o.1, file, TOPIC_TRUTH_ODOM, o.0, t)?,
                velocity: velocity_of(&o.1.twist, file, TOPIC_TRUTH_ODOM, o.0, t)?,
                wheels: wheels_of(&j.1, file, TOPIC_TRUTH_JOINTS, j.0, t)?,
            }),
            (o, _) => {
                let missing = if o.is_none() {
                    TOPIC_TRUTH_ODOM
                } else {
                    TOPIC_TRUTH_JOINTS
                };
                return Err(Error::log(
                    file,
                    format!("topic {missing}"),
                    format!(
                        "no message at log time {:.9} s, though the other ground-truth topic has one",
                        t as f64 * 1e-9
                    ),
                ));
            }
        };
        let reference = if icp.1.twist_covariance[0] == -1.0 {
            None
        } else {
            Some(velocity_of(&icp.1.twist, file, TOPIC_ICP_ODOM, icp.0, t)?)
        };
        let i = &imu.1;
        let imu_reading = ImuReading {
            wz_rad_s: i.angular_velocity.z,
            ax_m_s2: i.linear_acceleration.x,
            ay_m_s2: i.linear_acceleration.y,
            az_m_s2: i.linear_acceleration.z,
        };
        let finite = [
            imu_reading.wz_rad_s,
            imu_reading.ax_m_s2,
            imu_reading.ay_m_s2,
            imu_reading.az_m_s2,
        ]
        .iter()
        .all(|v| v.is_finite());
        if !finite {
            return Err(Error::log(
                file,
                msg_loc(TOPIC_IMU, imu.0, t),
                format!("non-finite reading {imu_reading:?}"),
            ));
        }
        let m = Measurement {
            cmd: wheels_of(&cmd.1, file, TOPIC_WHEEL_CMD, cmd.0, t)?,
            enc: wheels_of(&enc.1, file, TOPIC_JOINT_STATES, enc.0, t)?,
            pose: pose_of(&icp.1, file, TOPIC_ICP_ODOM, icp.0, t)?,
            imu: imu_reading,
            reference,
            truth,
        };
        let (phase, stamp_s) = phase_of(mk, t).map_err(|m| Error::log(file, &loc, m))?;
        frames.push(Frame { stamp_s, phase, m });
    }
    // Messages that no marker claims mean a damaged or hand-edited file.
    let orphan = |topic: &str, keys: &mut dyn Iterator<Item = (&u64, &u64)>| {
        for (t, idx) in keys {
            if !d.marker.contains_key(t) {
                return Err(Error::log(
                    file,
                    msg_loc(topic, *idx, *t),
                    format!("no {TOPIC_MARKER} message at this log time"),
                ));
            }
        }
        Ok(())
    };
    orphan(TOPIC_WHEEL_CMD, &mut d.wheel_cmd.iter().map(|(t, v)| (t, &v.0)))?;
    orphan(
        TOPIC_JOINT_STATES,
        &mut d.joint_states.iter().map(|(t, v)| (t, &v.0)),
    )?;
    orphan(TOPIC_ICP_ODOM, &mut d.icp_odom.iter().map(|(t, v)| (t, &v.0)))?;
    orphan(TOPIC_IMU, &mut d.imu.iter().map(|(t, v)| (t, &v.0)))?;
    orphan(TOPIC_TRUTH_ODOM, &mut d.truth_odom.iter().map(|(t, v)| (t, &v.0)))?;
    orphan(
        TOPIC_TRUTH_JOINTS,
        &mut d.truth_joints.iter().map(|(t, v)| (t, &v.0)),
    )?;
    Ok(frames)
}

/// The message of `topic` at log time `t`, or an error naming the marker that needs it.
fn at<'a, T>(m: &'a ByTime<T>, t: u64, topic: &str, marker_loc: &str, file: &Path) -> Result<&'a (u64, T)> {
    m.get(&t).ok_or_else(|| {
        Error::log(
            file,
            format!("topic {topic}"),
            format!(
                "no message at log time {:.9} s, where {marker_loc} is",
                t as f64 * 1e-9
            ),
        )
    })
}

fn phase_of(mk: &DriveMarker, t: u64) -> std::result::Result<(Phase, f64), String> {
    let stamp_s = mk.stamp;
    match stamp_to_ns(stamp_s) {
        Ok(ns) if ns == t => {}
        _ => {
            return Err(format!(
                "stamp {stamp_s} s does not match the log time {:.9} s - 1 s",
                t as f64 * 1e-9
            ))
        }
    }
    let phase = match mk.phase.as_str() {
        "step" => {
            if !mk.t_in_step.is_finite() {
                return Err(format!("t_in_step {} is not finite", mk.t_in_step));
            }
            Phase::Step {
                step: mk.step,
                attempt: mk.attempt,
                window: mk.window,
                k: mk.k,
                t_in_step_s: mk.t_in_step,
            }
        }
        "reorient" => Phase::Reorient { step: mk.step },
        "idle" => Phase::Idle,
        p => return Err(format!("phase `{p}`, expected step, reorient or idle")),
    };
    Ok((phase, stamp_s))
}

fn wheels_of(j: &JointState, file: &Path, topic: &str, idx: u64, t: u64) -> Result<WheelSpeeds> {
    let err = |m: String| Error::log(file, msg_loc(topic, idx, t), m);
    if j.velocity.len() != j.name.len() {
        return Err(err(format!(
            "{} names but {} velocities",
            j.name.len(),
            j.velocity.len()
        )));
    }
    let get = |joint: &str| {
        let i = j
            .name
            .iter()
            .position(|n| n == joint)
            .ok_or_else(|| err(format!("no joint `{joint}` in {:?}", j.name)))?;
        let v = j.velocity[i];
        if v.is_finite() {
            Ok(v)
        } else {
            Err(err(format!("velocity of `{joint}` is {v}")))
        }
    };
    Ok(WheelSpeeds::new(get(JOINT_LEFT)?, get(JOINT_RIGHT)?))
}

fn velocity_of(tw: &Twist, file: &Path, topic: &str, idx: u64, t: u64) -> Result<BodyVelocity> {
    let v = BodyVelocity::new(tw.linear.x, tw.linear.y, tw.angular.z);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::log(
            file,
            msg_loc(topic, idx, t),
            format!("non-finite twist {v:?}"),
        ))
    }
}

fn pose_of(o: &Odometry, file: &Path, topic: &str, idx: u64, t: u64) -> Result<Pose> {
    let err = |m: String| Error::log(file, msg_loc(topic, idx, t), m);
    let (p, q) = (o.pose.position, o.pose.orientation);
    let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
    if !(norm.is_finite() && (norm - 1.0).abs() < 1e-6) {
        return Err(err(format!("orientation {q:?} is not a unit quaternion")));
    }
    let uq = nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z));
    let (roll_rad, pitch_rad, yaw_rad) = uq.euler_angles();
    let pose = Pose {
        x_m: p.x,
        y_m: p.y,
        z_m: p.z,
        roll_rad,
        pitch_rad,
        yaw_rad,
    };
    if pose.is_finite() {
        Ok(pose)
    } else {
        Err(err(format!("non-finite position {p:?}")))
    }
}
