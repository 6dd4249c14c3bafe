//! A drive-sim ROS 2 MCAP file back to frames.

use super::convert::{msg_loc, phase_of, pose_of, velocity_of, wheels_of};
use super::*;
use crate::cdr::CdrError;
use crate::ros_msgs::{DriveMarker, Imu, JointState, Odometry, RosMessage};
use crate::{DriveLog, Frame, GroundTruth, ImuReading, LogMeta, Measurement, Phase, Pose};
use drive_sim_model::error::Result;
use drive_sim_model::kinematics::{BodyVelocity, WheelSpeeds};

/// Reads a drive-sim MCAP log into the common [`DriveLog`].
pub fn read_mcap(path: impl AsRef<Path>) -> Result<DriveLog> {
    let (meta, frames) = read_mcap_frames(path)?;
    Ok(DriveLog::from_frames(meta, &frames))
}

/// Reads a drive-sim MCAP log into its metadata and frames, streaming the file (one chunk in
/// memory at a time).
pub fn read_mcap_frames(path: impl AsRef<Path>) -> Result<(LogMeta, Vec<Frame>)> {
    let path = path.as_ref();
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    decode_from(std::io::BufReader::with_capacity(1 << 20, file), path)
}

/// Messages of one topic, by log time; the value keeps the message index for errors.
type ByTime<T> = BTreeMap<u64, (u64, T)>;

/// The messages of a log, each turned into the domain value its frame needs as soon as it is
/// decoded (and checked there, its error naming the message): a ROS message is 10–20 times the
/// size of what the frame keeps of it (an odometry message carries two 36-element covariances),
/// and a 300-step log has 70000 frames of seven messages each.
#[derive(Default)]
struct Decoded {
    /// Phase and exact stamp, s.
    marker: ByTime<(Phase, f64)>,
    wheel_cmd: ByTime<WheelSpeeds>,
    joint_states: ByTime<WheelSpeeds>,
    /// Lidar pose and, when the source has one, its body-velocity estimate.
    icp_odom: ByTime<(Pose, Option<BodyVelocity>)>,
    imu: ByTime<ImuReading>,
    truth_odom: ByTime<(Pose, BodyVelocity)>,
    truth_joints: ByTime<WheelSpeeds>,
}

/// The topics the reader needs and their types; `/cmd_vel` and `/tf` are derived and ignored,
/// like any other topic a user may have added.
const READ_TOPICS: [(&str, &crate::ros_msgs::MsgDef); 7] = [
    (TOPIC_MARKER, &crate::ros_msgs::DRIVE_MARKER),
    (TOPIC_WHEEL_CMD, &crate::ros_msgs::JOINT_STATE),
    (TOPIC_JOINT_STATES, &crate::ros_msgs::JOINT_STATE),
    (TOPIC_ICP_ODOM, &crate::ros_msgs::ODOMETRY),
    (TOPIC_IMU, &crate::ros_msgs::IMU),
    (TOPIC_TRUTH_ODOM, &crate::ros_msgs::ODOMETRY),
    (TOPIC_TRUTH_JOINTS, &crate::ros_msgs::JOINT_STATE),
];

/// Longest record (or decompressed chunk) the reader accepts, bytes: drive-sim writes 1 MiB
/// chunks and sub-kB messages, other tools use chunks of a few MiB; a corrupted length must not
/// make the reader allocate more than this.
pub(crate) const RECORD_LENGTH_LIMIT: usize = 64 << 20;

fn checked_reader() -> mcap::sans_io::LinearReader {
    let opts = mcap::sans_io::LinearReaderOptions::default()
        .with_validate_chunk_crcs(true)
        .with_prevalidate_chunk_crcs(true)
        .with_validate_data_section_crc(true)
        .with_validate_summary_section_crc(true)
        .with_record_length_limit(RECORD_LENGTH_LIMIT);
    mcap::sans_io::LinearReader::new_with_options(opts)
}

/// Streams every record of an MCAP source to `f` in order, chunks unpacked, with every CRC
/// checked, borrowing each record instead of copying it, so skipped messages (point clouds) cost
/// no copy; reading stops when `f` returns `false`.
///
/// The `mcap` crate's `ChunkFlattener` does the same without a record length limit, so a
/// flipped bit in a chunk header makes it allocate exabytes and abort; this drives the crate's
/// sans-IO reader with the limit set.
pub(crate) fn for_each_record<R: std::io::Read>(
    mut src: R,
    f: &mut dyn FnMut(mcap::records::Record<'_>) -> bool,
) -> mcap::McapResult<()> {
    use mcap::sans_io::LinearReadEvent;
    let mut reader = checked_reader();
    while let Some(event) = reader.next_event() {
        match event? {
            LinearReadEvent::ReadRequest(need) => {
                let n = src.read(reader.insert(need))?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record { data, opcode } => {
                if !f(mcap::read::parse_record(opcode, data)?) {
                    break;
                }
            }
        }
    }
    Ok(())
}

/// Whether `path` is a drive-sim log rather than another ROS 2 MCAP file (a rosbag2 bag): the
/// writer puts its metadata record before any message, so the file's head tells.
pub fn is_drive_sim_mcap(path: &Path) -> Result<bool> {
    use mcap::records::Record;
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(4 << 20).read_to_end(&mut head))
        .map_err(|e| Error::io(path, e))?;
    let mut found = false;
    // A message before the metadata, or a head that does not parse: not a drive-sim log.
    let _ = for_each_record(&head[..], &mut |rec| match rec {
        Record::Metadata(m) if m.name == METADATA_NAME => {
            found = true;
            false
        }
        Record::Message { .. } => false,
        _ => true,
    });
    Ok(found)
}

/// Decodes an in-memory drive-sim MCAP log; `file` names it in errors.
pub fn decode_mcap(bytes: &[u8], file: &Path) -> Result<(LogMeta, Vec<Frame>)> {
    decode_from(bytes, file)
}

/// Decodes a drive-sim MCAP log from `src`; `file` names it in errors.
fn decode_from(src: impl std::io::Read, file: &Path) -> Result<(LogMeta, Vec<Frame>)> {
    use mcap::records::Record;
    // schema id -> (name, encoding)
    let mut schemas: BTreeMap<u16, (String, String)> = BTreeMap::new();
    // channel id -> index in READ_TOPICS, or None for topics the reader ignores
    let mut channels: BTreeMap<u16, Option<usize>> = BTreeMap::new();
    let mut per_topic = [0u64; READ_TOPICS.len()];
    let mut meta: Option<LogMeta> = None;
    let mut d = Decoded::default();
    let mut profile_seen = false;
    let mut messages = 0u64;
    let mut records = 0u64;
    let mut failed = None;
    let mut on_record = |rec: Record<'_>| -> Result<()> {
        records += 1;
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
                let Some(k) = *known else { return Ok(()) };
                let idx = per_topic[k];
                per_topic[k] += 1;
                let topic = READ_TOPICS[k].0;
                let t = header.log_time;
                let loc = || msg_loc(topic, idx, t);
                let de = |e: CdrError| Error::log(file, loc(), format!("does not decode: {e}"));
                let dup = || Error::log(file, loc(), "a second message at the same log time");
                // Decodes the message as `$ty`, turns it into what the frame keeps with `$keep`,
                // and files it under its log time.
                macro_rules! store {
                    ($map:expr, $ty:ty, $keep:expr) => {{
                        let m = <$ty>::from_cdr(&data).map_err(de)?;
                        let keep = $keep;
                        if $map.insert(t, (idx, keep(&m)?)).is_some() {
                            return Err(dup());
                        }
                    }};
                }
                let wheels = |j: &JointState| wheels_of(j, file, topic, idx, t);
                match topic {
                    TOPIC_MARKER => store!(d.marker, DriveMarker, |mk: &DriveMarker| {
                        phase_of(mk, t).map_err(|m| Error::log(file, loc(), m))
                    }),
                    TOPIC_WHEEL_CMD => store!(d.wheel_cmd, JointState, wheels),
                    TOPIC_JOINT_STATES => store!(d.joint_states, JointState, wheels),
                    TOPIC_ICP_ODOM => store!(d.icp_odom, Odometry, |o: &Odometry| -> Result<_> {
                        let pose = pose_of(o, file, topic, idx, t)?;
                        // A source without a velocity estimate says so in the covariance.
                        let reference = if o.twist.covariance[0] == -1.0 {
                            None
                        } else {
                            Some(velocity_of(&o.twist.twist, file, topic, idx, t)?)
                        };
                        Ok((pose, reference))
                    }),
                    TOPIC_IMU => store!(d.imu, Imu, |i: &Imu| imu_of(i, file, idx, t)),
                    TOPIC_TRUTH_ODOM => store!(d.truth_odom, Odometry, |o: &Odometry| -> Result<_> {
                        Ok((
                            pose_of(o, file, topic, idx, t)?,
                            velocity_of(&o.twist.twist, file, topic, idx, t)?,
                        ))
                    }),
                    _ => store!(d.truth_joints, JointState, wheels),
                }
            }
            _ => {}
        }
        Ok(())
    };
    let read = for_each_record(src, &mut |rec| match on_record(rec) {
        Ok(()) => true,
        Err(e) => {
            failed = Some(e);
            false
        }
    });
    if let Some(e) = failed {
        return Err(e);
    }
    read.map_err(|e| {
        mcap_err(
            file,
            &format!("MCAP record {records} (after {messages} messages)"),
            e,
        )
    })?;
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
    meta.validate()
        .map_err(|(field, m)| Error::log(file, format!("{loc} key `log_meta` at `{field}`"), m))?;
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
    for (&t, (idx, (phase, stamp_s))) in &d.marker {
        let loc = msg_loc(TOPIC_MARKER, *idx, t);
        let cmd = at(&d.wheel_cmd, t, TOPIC_WHEEL_CMD, &loc, file)?;
        let enc = at(&d.joint_states, t, TOPIC_JOINT_STATES, &loc, file)?;
        let icp = at(&d.icp_odom, t, TOPIC_ICP_ODOM, &loc, file)?;
        let imu = at(&d.imu, t, TOPIC_IMU, &loc, file)?;
        let truth = match (d.truth_odom.get(&t), d.truth_joints.get(&t)) {
            (None, None) => None,
            (Some((_, (pose, velocity))), Some((_, wheels))) => Some(GroundTruth {
                pose: *pose,
                velocity: *velocity,
                wheels: *wheels,
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
        let m = Measurement {
            cmd: cmd.1,
            enc: enc.1,
            pose: icp.1 .0,
            imu: imu.1,
            reference: icp.1 .1,
            truth,
        };
        frames.push(Frame {
            stamp_s: *stamp_s,
            phase: *phase,
            m,
        });
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

/// The IMU reading of a message; every value must be finite.
fn imu_of(i: &Imu, file: &Path, idx: u64, t: u64) -> Result<ImuReading> {
    let r = ImuReading {
        wz_rad_s: i.angular_velocity.z,
        ax_m_s2: i.linear_acceleration.x,
        ay_m_s2: i.linear_acceleration.y,
        az_m_s2: i.linear_acceleration.z,
    };
    if [r.wz_rad_s, r.ax_m_s2, r.ay_m_s2, r.az_m_s2]
        .iter()
        .all(|v| v.is_finite())
    {
        Ok(r)
    } else {
        Err(Error::log(
            file,
            msg_loc(TOPIC_IMU, idx, t),
            format!("non-finite reading {r:?}"),
        ))
    }
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
