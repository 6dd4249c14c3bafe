//! Frames to a ROS 2 MCAP file.

use super::container::{Container, ContainerWriter};
use super::convert::{body_twist, check_frame, ros_pose, set_marker, set_wheels, stamp_to_ns};
use super::*;
use crate::ros_msgs::{
    DriveMarker, Header, Imu, JointState, Odometry, Pose as RosPose, PoseWithCovariance, Quaternion,
    RosMessage, TfMessage, Time, Transform, TransformStamped, Twist, TwistStamped, TwistWithCovariance,
    Vector3,
};
use crate::{Frame, FrameSink, LogMeta, Pose};
use drive_sim_model::error::Result;
use drive_sim_model::kinematics::IdealDiffDrive;
use drive_sim_model::provenance::Provenance;
use std::fs::File;
use std::io::{BufWriter, Cursor, Seek, Write};

/// Uncompressed chunk size: about 450 frames of 2.3 kB, a good zstd window, still small enough
/// that Foxglove seeks quickly.
const CHUNK_SIZE: u64 = 1 << 20;

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
    w: ContainerWriter<W>,
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
    /// The messages of a frame, kept from one frame to the next (see [`FrameMessages`]).
    msgs: Option<Box<FrameMessages>>,
    /// Names the log in errors.
    file: PathBuf,
}

/// The messages of one frame, built once and updated in place: a frame writes nine messages
/// every 50 ms of simulated time, and building them anew (their frame ids, joint names and
/// vectors, about twenty allocations) cost more than encoding them.
struct FrameMessages {
    marker: DriveMarker,
    cmd_vel: TwistStamped,
    wheel_cmd: JointState,
    joint_states: JointState,
    icp_odom: Odometry,
    imu: Imu,
    tf: TfMessage,
    truth_odom: Odometry,
    truth_joints: JointState,
}

impl Default for FrameMessages {
    fn default() -> Self {
        let header = |frame_id: &str| Header {
            stamp: Time::default(),
            frame_id: frame_id.to_string(),
        };
        let odometry = || Odometry {
            header: header(FRAME_ODOM),
            child_frame_id: FRAME_BASE.into(),
            pose: PoseWithCovariance {
                pose: ros_pose(Pose::default()),
                covariance: [0.0; 36],
            },
            twist: TwistWithCovariance {
                twist: Twist::default(),
                covariance: [0.0; 36],
            },
        };
        let wheels = || JointState {
            header: header(""),
            name: vec![JOINT_LEFT.into(), JOINT_RIGHT.into()],
            position: Vec::new(),
            velocity: vec![0.0; 2],
            effort: Vec::new(),
        };
        let mut orientation_covariance = [0.0; 9];
        orientation_covariance[0] = -1.0;
        Self {
            marker: DriveMarker {
                header: header(""),
                ..Default::default()
            },
            cmd_vel: TwistStamped {
                header: header(FRAME_BASE),
                twist: Twist::default(),
            },
            wheel_cmd: wheels(),
            joint_states: wheels(),
            icp_odom: odometry(),
            imu: Imu {
                header: header(FRAME_BASE),
                orientation: Quaternion::default(),
                orientation_covariance,
                angular_velocity: Vector3::default(),
                angular_velocity_covariance: [0.0; 9],
                linear_acceleration: Vector3::default(),
                linear_acceleration_covariance: [0.0; 9],
            },
            tf: TfMessage {
                transforms: Vec::new(),
            },
            truth_odom: odometry(),
            truth_joints: wheels(),
        }
    }
}

impl FrameMessages {
    /// Stamps every header (the transforms' are stamped by [`Self::set_transforms`]).
    fn set_stamp(&mut self, stamp: Time) {
        for h in [
            &mut self.marker.header,
            &mut self.cmd_vel.header,
            &mut self.wheel_cmd.header,
            &mut self.joint_states.header,
            &mut self.icp_odom.header,
            &mut self.imu.header,
            &mut self.truth_odom.header,
            &mut self.truth_joints.header,
        ] {
            h.stamp = stamp;
        }
    }

    /// The `/tf` message: odom → base_link at `pose`, and odom → the ground truth's frame at
    /// `truth` when the frame has one.
    fn set_transforms(&mut self, stamp: Time, pose: RosPose, truth: Option<RosPose>) {
        let t = &mut self.tf.transforms;
        // Built once per run (or when a frame gains or loses its ground truth).
        if t.len() != 1 + usize::from(truth.is_some()) {
            *t = [Some(FRAME_BASE), truth.map(|_| FRAME_BASE_TRUTH)]
                .into_iter()
                .flatten()
                .map(|child| TransformStamped {
                    header: Header {
                        stamp,
                        frame_id: FRAME_ODOM.to_string(),
                    },
                    child_frame_id: child.into(),
                    transform: Transform::default(),
                })
                .collect();
        }
        for (ts, p) in t.iter_mut().zip([Some(pose), truth].into_iter().flatten()) {
            ts.header.stamp = stamp;
            ts.transform = Transform {
                translation: Vector3 {
                    x: p.position.x,
                    y: p.position.y,
                    z: p.position.z,
                },
                rotation: p.orientation,
            };
        }
    }
}

impl<W: Write + Seek> FrameEncoder<W> {
    fn new(
        container: Container,
        sink: W,
        meta: &LogMeta,
        file: &Path,
        provenance: Option<&Provenance>,
    ) -> Result<Self> {
        let library = format!("drive-sim {}", env!("CARGO_PKG_VERSION"));
        let e = |e| mcap_err(file, "header", e);
        let mut w = ContainerWriter::new(container, sink, &library, CHUNK_SIZE).map_err(e)?;
        let json = serde_json::to_string(meta)
            .map_err(|x| Error::log(file, "metadata", format!("cannot serialize: {x}")))?;
        let mut metadata = BTreeMap::from([
            ("format".to_string(), FORMAT.to_string()),
            ("log_meta".to_string(), json),
        ]);
        if let Some(p) = provenance {
            let p = serde_json::to_string(p)
                .map_err(|x| Error::log(file, "metadata", format!("cannot serialize: {x}")))?;
            metadata.insert("provenance".to_string(), p);
        }
        w.write_metadata(&mcap::records::Metadata {
            name: METADATA_NAME.into(),
            metadata,
        })
        .map_err(e)?;
        let mut topics = BTreeMap::new();
        let mut add = |w: &mut ContainerWriter<W>, topic: &'static str, def| -> Result<u16> {
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
            msgs: None,
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
        let r = self.w.write_message(&header, &data);
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
        // Formatted only on an error: a frame is written every 50 ms of simulated time.
        let frame_no = self.frames;
        let loc = || format!("frame {frame_no} (t = {} s)", f.stamp_s);
        check_frame(f).map_err(|m| Error::log(&self.file, loc(), m))?;
        let ns = stamp_to_ns(f.stamp_s).map_err(|m| Error::log(&self.file, loc(), m))?;
        if let Some(prev) = self.last_ns {
            if ns <= prev {
                return Err(Error::log(
                    &self.file,
                    loc(),
                    format!(
                        "stamp is not after the previous frame's ({} ns <= {} ns); \
                         MCAP frames must have strictly increasing stamps",
                        ns - EPOCH_OFFSET_NS,
                        prev - EPOCH_OFFSET_NS
                    ),
                ));
            }
        }
        let stamp = Time::from_ns(ns).ok_or_else(|| Error::log(&self.file, loc(), "stamp beyond 2038"))?;
        let m = &f.m;
        // Taken out while its messages are written (`put` borrows the encoder); an error drops
        // it and the next frame builds it again.
        let mut msgs: Box<FrameMessages> = self.msgs.take().unwrap_or_default();
        msgs.set_stamp(stamp);

        let ch = self.ch;
        set_marker(&mut msgs.marker, f);
        self.put(ch.marker, ns, &msgs.marker)?;
        msgs.cmd_vel.twist = body_twist(self.idd.body_from_wheels(m.cmd));
        self.put(ch.cmd_vel, ns, &msgs.cmd_vel)?;
        set_wheels(&mut msgs.wheel_cmd, m.cmd);
        self.put(ch.wheel_cmd, ns, &msgs.wheel_cmd)?;
        set_wheels(&mut msgs.joint_states, m.enc);
        self.put(ch.joint_states, ns, &msgs.joint_states)?;
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
        let pose = ros_pose(m.pose);
        msgs.icp_odom.pose.pose = pose;
        msgs.icp_odom.twist = TwistWithCovariance {
            twist,
            covariance: twist_covariance,
        };
        self.put(ch.icp_odom, ns, &msgs.icp_odom)?;
        msgs.imu.angular_velocity.z = m.imu.wz_rad_s;
        msgs.imu.linear_acceleration = Vector3 {
            x: m.imu.ax_m_s2,
            y: m.imu.ay_m_s2,
            z: m.imu.az_m_s2,
        };
        self.put(ch.imu, ns, &msgs.imu)?;
        let truth_pose = m.truth.map(|t| ros_pose(t.pose));
        msgs.set_transforms(stamp, pose, truth_pose);
        self.put(ch.tf, ns, &msgs.tf)?;
        if let (Some(t), Some(truth_pose)) = (m.truth, truth_pose) {
            let (odom, joints) = match self.truth_ch {
                Some(c) => c,
                None => {
                    let e = |e| mcap_err(&self.file, &loc(), e);
                    let o = add_channel(&mut self.w, TOPIC_TRUTH_ODOM, Odometry::DEF).map_err(e)?;
                    let j = add_channel(&mut self.w, TOPIC_TRUTH_JOINTS, JointState::DEF).map_err(e)?;
                    self.topics.insert(o, TOPIC_TRUTH_ODOM);
                    self.topics.insert(j, TOPIC_TRUTH_JOINTS);
                    self.truth_ch = Some((o, j));
                    (o, j)
                }
            };
            msgs.truth_odom.pose.pose = truth_pose;
            msgs.truth_odom.twist.twist = body_twist(t.velocity);
            self.put(odom, ns, &msgs.truth_odom)?;
            set_wheels(&mut msgs.truth_joints, t.wheels);
            self.put(joints, ns, &msgs.truth_joints)?;
        }
        self.msgs = Some(msgs);
        self.last_ns = Some(ns);
        self.frames += 1;
        Ok(())
    }

    /// Writes the summary; returns the sink and the per-topic counts.
    fn finish(self) -> Result<(W, u64, BTreeMap<String, u64>)> {
        let counts = self
            .topics
            .iter()
            .map(|(id, t)| (t.to_string(), self.counts.get(id).copied().unwrap_or(0) as u64))
            .collect();
        let sink = self.w.finish().map_err(|e| mcap_err(&self.file, "summary", e))?;
        Ok((sink, self.frames, counts))
    }
}

fn add_channel<W: Write + Seek>(
    w: &mut ContainerWriter<W>,
    topic: &str,
    def: &'static crate::ros_msgs::MsgDef,
) -> mcap::McapResult<u16> {
    let schema = w.add_schema(&def.schema_name(), "ros2msg", def.schema_text().as_bytes())?;
    let metadata = BTreeMap::from([(QOS_METADATA_KEY.to_string(), OFFERED_QOS_PROFILES.to_string())]);
    w.add_channel(schema, topic, "cdr", &metadata)
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

/// `NAME.interrupted.mcap` for the log `NAME.mcap`: where an interrupted run is closed.
pub fn interrupted_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}.interrupted.mcap"))
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
        Self::create_with_provenance(path, meta, None)
    }

    /// [`create`](Self::create), also recording `provenance` (version, schema version, file
    /// hashes, options) in the metadata record, under the key `provenance`.
    pub fn create_with_provenance(
        path: impl AsRef<Path>,
        meta: &LogMeta,
        provenance: Option<&Provenance>,
    ) -> Result<Self> {
        Self::create_with_container(path, meta, provenance, Container::default())
    }

    /// [`create_with_provenance`](Self::create_with_provenance) with a chosen container writer
    /// (the speed bench times ours against the `mcap` crate's).
    pub fn create_with_container(
        path: impl AsRef<Path>,
        meta: &LogMeta,
        provenance: Option<&Provenance>,
        container: Container,
    ) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let partial = partial_path(&path);
        // An existing log at `path` stays untouched until `finish` atomically renames the new
        // one over it: a failed run loses nothing that was already written.
        let file = File::create(&partial).map_err(|e| Error::io(&partial, e))?;
        let enc = FrameEncoder::new(
            container,
            BufWriter::with_capacity(1 << 16, file),
            meta,
            &partial,
            provenance,
        )?;
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
    pub fn finish(self) -> Result<McapSummary> {
        let path = self.path.clone();
        self.finish_to(path)
    }

    /// Closes a log cut short (SIGINT / SIGTERM) with a valid summary under
    /// [`interrupted_path`] of its final path, so that any reader opens it and nobody takes
    /// it for a complete run. Only frames already written are in it.
    pub fn finish_interrupted(self) -> Result<McapSummary> {
        let path = interrupted_path(&self.path);
        self.finish_to(path)
    }

    fn finish_to(mut self, path: PathBuf) -> Result<McapSummary> {
        self.path = path;
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
    encode_mcap_with(Container::default(), meta, frames, file)
}

/// [`encode_mcap`] with a chosen container writer: the tests and the MCAP bench hold ours
/// against the `mcap` crate's.
pub fn encode_mcap_with(
    container: Container,
    meta: &LogMeta,
    frames: &[Frame],
    file: &Path,
) -> Result<Vec<u8>> {
    let mut enc = FrameEncoder::new(container, Cursor::new(Vec::new()), meta, file, None)?;
    for f in frames {
        enc.write_frame(f)?;
    }
    Ok(enc.finish()?.0.into_inner())
}
