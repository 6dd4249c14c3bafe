//! The ROS 2 message types of the DRIVE logs: plain structs, their CDR encoding, and their
//! `ros2msg` schema text with every dependency embedded, as rosbag2 writes it.
//!
//! A schema is the type's own definition followed, for each type it uses (transitively, in
//! first-use order), by a line of 80 `=`, a line `MSG: pkg/Name` and that type's definition.
//! Field types are written fully qualified (`geometry_msgs/Vector3`, not `Vector3`) so no reader
//! has to resolve names relative to a package. The standard definitions are those of ROS 2
//! (Humble and later) with comments stripped; field order and types are what the wire carries.

use super::cdr::{CdrReader, CdrResult, CdrWriter};

/// One message definition and the definitions it uses directly.
#[derive(Debug)]
pub struct MsgDef {
    /// `pkg/Name` (the form used after `MSG:`).
    pub name: &'static str,
    /// The `.msg` text.
    pub text: &'static str,
    /// Types used by the fields.
    pub deps: &'static [&'static MsgDef],
}

impl MsgDef {
    /// The schema name ROS 2 bags use: `pkg/msg/Name`.
    pub fn schema_name(&self) -> String {
        match self.name.split_once('/') {
            Some((pkg, name)) => format!("{pkg}/msg/{name}"),
            None => self.name.to_string(),
        }
    }

    /// The full schema text: this definition, then every dependency once, depth first.
    pub fn schema_text(&'static self) -> String {
        fn collect(d: &'static MsgDef, seen: &mut Vec<&'static str>, out: &mut String) {
            for dep in d.deps {
                if !seen.contains(&dep.name) {
                    seen.push(dep.name);
                    out.push_str(&"=".repeat(80));
                    out.push_str("\nMSG: ");
                    out.push_str(dep.name);
                    out.push('\n');
                    out.push_str(dep.text);
                    collect(dep, seen, out);
                }
            }
        }
        let mut out = self.text.to_string();
        let mut seen = vec![self.name];
        collect(self, &mut seen, &mut out);
        out
    }
}

/// `builtin_interfaces/Time`.
pub static TIME: MsgDef = MsgDef {
    name: "builtin_interfaces/Time",
    text: "int32 sec\nuint32 nanosec\n",
    deps: &[],
};
/// `std_msgs/Header`.
pub static HEADER: MsgDef = MsgDef {
    name: "std_msgs/Header",
    text: "builtin_interfaces/Time stamp\nstring frame_id\n",
    deps: &[&TIME],
};
/// `geometry_msgs/Vector3`.
pub static VECTOR3: MsgDef = MsgDef {
    name: "geometry_msgs/Vector3",
    text: "float64 x\nfloat64 y\nfloat64 z\n",
    deps: &[],
};
/// `geometry_msgs/Point`.
pub static POINT: MsgDef = MsgDef {
    name: "geometry_msgs/Point",
    text: "float64 x\nfloat64 y\nfloat64 z\n",
    deps: &[],
};
/// `geometry_msgs/Quaternion` (with the ROS 2 default values).
pub static QUATERNION: MsgDef = MsgDef {
    name: "geometry_msgs/Quaternion",
    text: "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    deps: &[],
};
/// `geometry_msgs/Twist`.
pub static TWIST: MsgDef = MsgDef {
    name: "geometry_msgs/Twist",
    text: "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n",
    deps: &[&VECTOR3],
};
/// `geometry_msgs/TwistStamped`.
pub static TWIST_STAMPED: MsgDef = MsgDef {
    name: "geometry_msgs/TwistStamped",
    text: "std_msgs/Header header\ngeometry_msgs/Twist twist\n",
    deps: &[&HEADER, &TWIST],
};
/// `geometry_msgs/Pose`.
pub static POSE: MsgDef = MsgDef {
    name: "geometry_msgs/Pose",
    text: "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
    deps: &[&POINT, &QUATERNION],
};
/// `geometry_msgs/PoseWithCovariance`.
pub static POSE_WITH_COVARIANCE: MsgDef = MsgDef {
    name: "geometry_msgs/PoseWithCovariance",
    text: "geometry_msgs/Pose pose\nfloat64[36] covariance\n",
    deps: &[&POSE],
};
/// `geometry_msgs/TwistWithCovariance`.
pub static TWIST_WITH_COVARIANCE: MsgDef = MsgDef {
    name: "geometry_msgs/TwistWithCovariance",
    text: "geometry_msgs/Twist twist\nfloat64[36] covariance\n",
    deps: &[&TWIST],
};
/// `nav_msgs/Odometry`.
pub static ODOMETRY: MsgDef = MsgDef {
    name: "nav_msgs/Odometry",
    text: "std_msgs/Header header\nstring child_frame_id\n\
           geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
    deps: &[&HEADER, &POSE_WITH_COVARIANCE, &TWIST_WITH_COVARIANCE],
};
/// `sensor_msgs/JointState`.
pub static JOINT_STATE: MsgDef = MsgDef {
    name: "sensor_msgs/JointState",
    text: "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n\
           float64[] effort\n",
    deps: &[&HEADER],
};
/// `sensor_msgs/Imu`.
pub static IMU: MsgDef = MsgDef {
    name: "sensor_msgs/Imu",
    text: "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n\
           float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n\
           float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n\
           float64[9] linear_acceleration_covariance\n",
    deps: &[&HEADER, &QUATERNION, &VECTOR3],
};
/// `geometry_msgs/Transform`.
pub static TRANSFORM: MsgDef = MsgDef {
    name: "geometry_msgs/Transform",
    text: "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n",
    deps: &[&VECTOR3, &QUATERNION],
};
/// `geometry_msgs/TransformStamped`.
pub static TRANSFORM_STAMPED: MsgDef = MsgDef {
    name: "geometry_msgs/TransformStamped",
    text: "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
    deps: &[&HEADER, &TRANSFORM],
};
/// `tf2_msgs/TFMessage`.
pub static TF_MESSAGE: MsgDef = MsgDef {
    name: "tf2_msgs/TFMessage",
    text: "geometry_msgs/TransformStamped[] transforms\n",
    deps: &[&TRANSFORM_STAMPED],
};
/// `drive_sim_msgs/DriveMarker`: where the DRIVE protocol is at one logged tick.
pub static DRIVE_MARKER: MsgDef = MsgDef {
    name: "drive_sim_msgs/DriveMarker",
    text: "# Where the DRIVE protocol is at one logged tick (drive-sim).\n\
           std_msgs/Header header\n\
           # \"step\" (executing a command), \"reorient\" (after an interruption) or \"idle\".\n\
           string phase\n\
           # Step index (the interrupted step while re-orienting; 0 when idle).\n\
           uint32 step\n\
           # Attempt of this step, from 0; an interruption starts a new attempt (0 unless step).\n\
           uint32 attempt\n\
           # Window index: 0 transient, 1.. steady (0 unless step).\n\
           uint32 window\n\
           # Sample index inside the window (0 unless step).\n\
           uint32 k\n\
           # Time since the start of the attempt, s (0 unless step).\n\
           float64 t_in_step\n\
           # Log time, s, exactly as the simulator produced it (the header stamp is this plus a\n\
           # 1 s offset, rounded to the nanosecond).\n\
           float64 stamp\n",
    deps: &[&HEADER],
};

/// A message with a schema and a CDR encoding.
pub trait RosMessage: Sized {
    /// Its definition.
    const DEF: &'static MsgDef;
    /// Appends the fields to `w`.
    fn encode(&self, w: &mut CdrWriter);
    /// Reads the fields from `r`.
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self>;

    /// Encodes a whole message (encapsulation header included) into `buf`'s allocation.
    fn to_cdr(&self, buf: Vec<u8>) -> Vec<u8> {
        let mut w = CdrWriter::reusing(buf);
        self.encode(&mut w);
        w.into_bytes()
    }

    /// Decodes a whole message, refusing trailing bytes beyond the 4-byte padding.
    fn from_cdr(bytes: &[u8]) -> CdrResult<Self> {
        let mut r = CdrReader::new(bytes)?;
        let m = Self::decode(&mut r)?;
        if r.remaining() > 3 {
            return Err(r.err(format!(
                "{} bytes left after the last field of {}",
                r.remaining(),
                Self::DEF.name
            )));
        }
        Ok(m)
    }
}

/// `builtin_interfaces/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, < 1e9.
    pub nanosec: u32,
}

impl Time {
    /// From nanoseconds since the epoch; `None` beyond 2038 (`int32` seconds).
    pub fn from_ns(ns: u64) -> Option<Self> {
        Some(Self {
            sec: i32::try_from(ns / 1_000_000_000).ok()?,
            nanosec: (ns % 1_000_000_000) as u32,
        })
    }

    /// Nanoseconds since the epoch; `None` if negative or `nanosec` is out of range.
    pub fn to_ns(self) -> Option<u64> {
        if self.sec < 0 || self.nanosec >= 1_000_000_000 {
            return None;
        }
        Some(self.sec as u64 * 1_000_000_000 + self.nanosec as u64)
    }

    fn encode(&self, w: &mut CdrWriter) {
        w.i32(self.sec);
        w.u32(self.nanosec);
    }

    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            sec: r.field("sec", |r| r.i32())?,
            nanosec: r.field("nanosec", |r| r.u32())?,
        })
    }
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Header {
    /// Time of the data.
    pub stamp: Time,
    /// Frame the data is expressed in.
    pub frame_id: String,
}

impl RosMessage for Header {
    const DEF: &'static MsgDef = &HEADER;
    fn encode(&self, w: &mut CdrWriter) {
        self.stamp.encode(w);
        w.string(&self.frame_id);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            stamp: r.field("stamp", Time::decode)?,
            frame_id: r.field("frame_id", |r| r.string())?,
        })
    }
}

/// `geometry_msgs/Vector3` (also `Point`, same layout).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Vector3 {
    fn encode(&self, w: &mut CdrWriter) {
        w.f64(self.x);
        w.f64(self.y);
        w.f64(self.z);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            x: r.field("x", |r| r.f64())?,
            y: r.field("y", |r| r.f64())?,
            z: r.field("z", |r| r.f64())?,
        })
    }
}

/// `geometry_msgs/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

impl Quaternion {
    fn encode(&self, w: &mut CdrWriter) {
        w.f64(self.x);
        w.f64(self.y);
        w.f64(self.z);
        w.f64(self.w);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            x: r.field("x", |r| r.f64())?,
            y: r.field("y", |r| r.f64())?,
            z: r.field("z", |r| r.f64())?,
            w: r.field("w", |r| r.f64())?,
        })
    }
}

/// `geometry_msgs/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Twist {
    /// Linear velocity, m/s.
    pub linear: Vector3,
    /// Angular velocity, rad/s.
    pub angular: Vector3,
}

impl Twist {
    fn encode(&self, w: &mut CdrWriter) {
        self.linear.encode(w);
        self.angular.encode(w);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            linear: r.field("linear", Vector3::decode)?,
            angular: r.field("angular", Vector3::decode)?,
        })
    }
}

/// `geometry_msgs/TwistStamped`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TwistStamped {
    /// Header.
    pub header: Header,
    /// Twist.
    pub twist: Twist,
}

impl RosMessage for TwistStamped {
    const DEF: &'static MsgDef = &TWIST_STAMPED;
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        self.twist.encode(w);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            header: r.field("header", Header::decode)?,
            twist: r.field("twist", Twist::decode)?,
        })
    }
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// Position (a `geometry_msgs/Point`), m.
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

impl Pose {
    fn encode(&self, w: &mut CdrWriter) {
        self.position.encode(w);
        self.orientation.encode(w);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            position: r.field("position", Vector3::decode)?,
            orientation: r.field("orientation", Quaternion::decode)?,
        })
    }
}

/// `nav_msgs/Odometry`, with the `*WithCovariance` wrappers flattened.
#[derive(Debug, Clone, PartialEq)]
pub struct Odometry {
    /// Header; `frame_id` is the frame of the pose.
    pub header: Header,
    /// Frame of the twist.
    pub child_frame_id: String,
    /// `pose.pose`.
    pub pose: Pose,
    /// `pose.covariance`, row-major (x, y, z, rot x, rot y, rot z).
    pub pose_covariance: [f64; 36],
    /// `twist.twist`.
    pub twist: Twist,
    /// `twist.covariance`.
    pub twist_covariance: [f64; 36],
}

impl RosMessage for Odometry {
    const DEF: &'static MsgDef = &ODOMETRY;
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.child_frame_id);
        self.pose.encode(w);
        w.f64_array(&self.pose_covariance);
        self.twist.encode(w);
        w.f64_array(&self.twist_covariance);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        let header = r.field("header", Header::decode)?;
        let child_frame_id = r.field("child_frame_id", |r| r.string())?;
        let (pose, pose_covariance) = r.field("pose", |r| {
            Ok((
                r.field("pose", Pose::decode)?,
                r.field("covariance", |r| r.f64_array::<36>())?,
            ))
        })?;
        let (twist, twist_covariance) = r.field("twist", |r| {
            Ok((
                r.field("twist", Twist::decode)?,
                r.field("covariance", |r| r.f64_array::<36>())?,
            ))
        })?;
        Ok(Self {
            header,
            child_frame_id,
            pose,
            pose_covariance,
            twist,
            twist_covariance,
        })
    }
}

/// `sensor_msgs/JointState`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointState {
    /// Header.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions, rad (empty when not measured).
    pub position: Vec<f64>,
    /// Velocities, rad/s.
    pub velocity: Vec<f64>,
    /// Efforts, N m (empty when not measured).
    pub effort: Vec<f64>,
}

impl RosMessage for JointState {
    const DEF: &'static MsgDef = &JOINT_STATE;
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.seq_len(self.name.len());
        for n in &self.name {
            w.string(n);
        }
        w.f64_seq(&self.position);
        w.f64_seq(&self.velocity);
        w.f64_seq(&self.effort);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            header: r.field("header", Header::decode)?,
            name: r.field("name", |r| r.string_seq())?,
            position: r.field("position", |r| r.f64_seq())?,
            velocity: r.field("velocity", |r| r.f64_seq())?,
            effort: r.field("effort", |r| r.f64_seq())?,
        })
    }
}

/// `sensor_msgs/Imu`.
#[derive(Debug, Clone, PartialEq)]
pub struct Imu {
    /// Header.
    pub header: Header,
    /// Orientation (meaningless when `orientation_covariance[0] == -1`).
    pub orientation: Quaternion,
    /// Row-major covariance; element 0 = -1 means "no orientation estimate".
    pub orientation_covariance: [f64; 9],
    /// Angular velocity, rad/s.
    pub angular_velocity: Vector3,
    /// Covariance (all zero: unknown).
    pub angular_velocity_covariance: [f64; 9],
    /// Linear acceleration (specific force), m/s².
    pub linear_acceleration: Vector3,
    /// Covariance (all zero: unknown).
    pub linear_acceleration_covariance: [f64; 9],
}

impl RosMessage for Imu {
    const DEF: &'static MsgDef = &IMU;
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        self.orientation.encode(w);
        w.f64_array(&self.orientation_covariance);
        self.angular_velocity.encode(w);
        w.f64_array(&self.angular_velocity_covariance);
        self.linear_acceleration.encode(w);
        w.f64_array(&self.linear_acceleration_covariance);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            header: r.field("header", Header::decode)?,
            orientation: r.field("orientation", Quaternion::decode)?,
            orientation_covariance: r.field("orientation_covariance", |r| r.f64_array::<9>())?,
            angular_velocity: r.field("angular_velocity", Vector3::decode)?,
            angular_velocity_covariance: r.field("angular_velocity_covariance", |r| r.f64_array::<9>())?,
            linear_acceleration: r.field("linear_acceleration", Vector3::decode)?,
            linear_acceleration_covariance: r
                .field("linear_acceleration_covariance", |r| r.f64_array::<9>())?,
        })
    }
}

/// `geometry_msgs/TransformStamped`, with the `Transform` flattened.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TransformStamped {
    /// Header; `frame_id` is the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// `transform.translation`, m.
    pub translation: Vector3,
    /// `transform.rotation`.
    pub rotation: Quaternion,
}

impl TransformStamped {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.child_frame_id);
        self.translation.encode(w);
        self.rotation.encode(w);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        let header = r.field("header", Header::decode)?;
        let child_frame_id = r.field("child_frame_id", |r| r.string())?;
        let (translation, rotation) = r.field("transform", |r| {
            Ok((
                r.field("translation", Vector3::decode)?,
                r.field("rotation", Quaternion::decode)?,
            ))
        })?;
        Ok(Self {
            header,
            child_frame_id,
            translation,
            rotation,
        })
    }
}

/// `tf2_msgs/TFMessage`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TfMessage {
    /// Transforms.
    pub transforms: Vec<TransformStamped>,
}

impl RosMessage for TfMessage {
    const DEF: &'static MsgDef = &TF_MESSAGE;
    fn encode(&self, w: &mut CdrWriter) {
        w.seq_len(self.transforms.len());
        for t in &self.transforms {
            t.encode(w);
        }
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        let n = r.field("transforms", |r| r.seq_len())?;
        let transforms = r.field("transforms", |r| {
            (0..n).map(|_| TransformStamped::decode(r)).collect()
        })?;
        Ok(Self { transforms })
    }
}

/// `drive_sim_msgs/DriveMarker`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DriveMarker {
    /// Header (frame_id empty: the marker is not spatial).
    pub header: Header,
    /// `step`, `reorient` or `idle`.
    pub phase: String,
    /// Step index.
    pub step: u32,
    /// Attempt index.
    pub attempt: u32,
    /// Window index.
    pub window: u32,
    /// Sample index in the window.
    pub k: u32,
    /// Time since the start of the attempt, s.
    pub t_in_step: f64,
    /// Exact log time, s.
    pub stamp: f64,
}

impl RosMessage for DriveMarker {
    const DEF: &'static MsgDef = &DRIVE_MARKER;
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.phase);
        w.u32(self.step);
        w.u32(self.attempt);
        w.u32(self.window);
        w.u32(self.k);
        w.f64(self.t_in_step);
        w.f64(self.stamp);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        Ok(Self {
            header: r.field("header", Header::decode)?,
            phase: r.field("phase", |r| r.string())?,
            step: r.field("step", |r| r.u32())?,
            attempt: r.field("attempt", |r| r.u32())?,
            window: r.field("window", |r| r.u32())?,
            k: r.field("k", |r| r.u32())?,
            t_in_step: r.field("t_in_step", |r| r.f64())?,
            stamp: r.field("stamp", |r| r.f64())?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schema_embeds_each_dependency_once_in_rosbag2_form() {
        let s = ODOMETRY.schema_text();
        let sep = format!("{}\nMSG: ", "=".repeat(80));
        let sections: Vec<&str> = s.split(&sep).collect();
        let names: Vec<&str> = sections[1..].iter().map(|x| x.lines().next().unwrap()).collect();
        assert_eq!(
            names,
            [
                "std_msgs/Header",
                "builtin_interfaces/Time",
                "geometry_msgs/PoseWithCovariance",
                "geometry_msgs/Pose",
                "geometry_msgs/Point",
                "geometry_msgs/Quaternion",
                "geometry_msgs/TwistWithCovariance",
                "geometry_msgs/Twist",
                "geometry_msgs/Vector3",
            ]
        );
        assert!(sections[0].starts_with("std_msgs/Header header\nstring child_frame_id\n"));
        assert_eq!(ODOMETRY.schema_name(), "nav_msgs/msg/Odometry");
        // Every type a field names is defined in the text.
        for d in [
            &ODOMETRY,
            &IMU,
            &TF_MESSAGE,
            &JOINT_STATE,
            &TWIST_STAMPED,
            &DRIVE_MARKER,
        ] {
            let s = d.schema_text();
            for line in s
                .lines()
                .filter(|l| !l.starts_with('#') && !l.starts_with("MSG:"))
            {
                let ty = line.split_whitespace().next().unwrap_or("");
                let ty = ty.split('[').next().unwrap();
                if ty.contains('/') {
                    assert!(s.contains(&format!("MSG: {ty}\n")), "{} lacks {ty}", d.name);
                }
            }
        }
    }

    #[test]
    fn header_bytes_by_hand_and_round_trip() {
        let h = Header {
            stamp: Time {
                sec: 1,
                nanosec: 50_000_000,
            },
            frame_id: "odom".into(),
        };
        let b = h.to_cdr(Vec::new());
        let mut e = vec![0, 1, 0, 0, 1, 0, 0, 0];
        e.extend(50_000_000u32.to_le_bytes());
        e.extend([5, 0, 0, 0]);
        e.extend(b"odom\0");
        assert_eq!(b, e);
        assert_eq!(Header::from_cdr(&b).unwrap(), h);

        let o = Odometry {
            header: h,
            child_frame_id: "base_link".into(),
            pose: Pose {
                position: Vector3 {
                    x: 1.0,
                    y: -2.0,
                    z: 0.5,
                },
                orientation: Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.6,
                    w: 0.8,
                },
            },
            pose_covariance: [0.25; 36],
            twist: Twist {
                linear: Vector3 {
                    x: 0.3,
                    y: 0.0,
                    z: 0.0,
                },
                angular: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: -0.1,
                },
            },
            twist_covariance: [0.0; 36],
        };
        let b = o.to_cdr(Vec::new());
        // Header ends at 17; child_frame_id: pad to 20, length 20..24, "base_link\0" 24..34;
        // pad to 40, then 7 + 36 + 6 + 36 doubles.
        assert_eq!(b.len(), 4 + 40 + 8 * (7 + 36 + 6 + 36));
        assert_eq!(Odometry::from_cdr(&b).unwrap(), o);
        // Trailing garbage and a wrong type are refused.
        let mut longer = b.clone();
        longer.extend([0; 8]);
        assert!(Odometry::from_cdr(&longer).is_err());
        assert!(Imu::from_cdr(&b).is_err());
    }
}
