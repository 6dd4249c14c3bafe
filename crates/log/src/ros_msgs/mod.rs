//! The ROS 2 message types of the DRIVE logs, each declared once.
//!
//! One `ros_message!` declaration per type gives the Rust struct, its [`MsgDef`] (from which
//! the `ros2msg` schema text is generated, every dependency embedded as rosbag2 writes it) and
//! its CDR encoding and decoding (field by field, through [`RosField`], with
//! [`super::cdr`] as the one CDR implementation). Nothing about a message is written twice, so
//! the schema a file declares and the bytes it carries cannot drift apart.
//!
//! A schema is the type's own definition followed, for each type it uses (transitively, in
//! first-use order), by a line of 80 `=`, a line `MSG: pkg/Name` and that type's definition.
//! Field types are written fully qualified (`geometry_msgs/Vector3`, not `Vector3`) so no reader
//! has to resolve names relative to a package. The standard definitions are those of ROS 2
//! (Humble and later) with comments stripped; field order and types are what the wire carries.

use super::cdr::{CdrReader, CdrResult, CdrWriter};

/// The type of one field, as a schema writes it.
#[derive(Debug)]
pub enum FieldType {
    /// A primitive (`float64`, `uint32`, `string`, ...).
    Primitive(&'static str),
    /// Another message.
    Message(&'static MsgDef),
    /// A fixed-size array (`float64[36]`): no count on the wire.
    Array(&'static FieldType, usize),
    /// An unbounded sequence (`float64[]`): a `uint32` count, then the elements.
    Sequence(&'static FieldType),
}

impl FieldType {
    /// The type as written in a `.msg` file.
    pub fn ros_name(&self) -> String {
        match self {
            FieldType::Primitive(p) => p.to_string(),
            FieldType::Message(d) => d.name.to_string(),
            FieldType::Array(t, n) => format!("{}[{n}]", t.ros_name()),
            FieldType::Sequence(t) => format!("{}[]", t.ros_name()),
        }
    }

    /// The message this field's elements are, if any.
    pub fn message(&self) -> Option<&'static MsgDef> {
        match self {
            FieldType::Primitive(_) => None,
            FieldType::Message(d) => Some(d),
            FieldType::Array(t, _) | FieldType::Sequence(t) => t.message(),
        }
    }
}

/// One field of a message definition.
#[derive(Debug)]
pub struct FieldDef {
    /// Field name.
    pub name: &'static str,
    /// Field type.
    pub ty: &'static FieldType,
    /// Default value written after the name (`float64 w 1`), if any.
    pub default: Option<&'static str>,
    /// Comment lines written above the field (without the `# `).
    pub comments: &'static [&'static str],
}

/// One message definition: its name and fields, from which the schema text is generated.
#[derive(Debug)]
pub struct MsgDef {
    /// `pkg/Name` (the form used after `MSG:`).
    pub name: &'static str,
    /// Comment lines at the top of the definition (without the `# `).
    pub comments: &'static [&'static str],
    /// Fields in wire order.
    pub fields: &'static [FieldDef],
}

impl MsgDef {
    /// The schema name ROS 2 bags use: `pkg/msg/Name`.
    pub fn schema_name(&self) -> String {
        match self.name.split_once('/') {
            Some((pkg, name)) => format!("{pkg}/msg/{name}"),
            None => self.name.to_string(),
        }
    }

    /// The `.msg` text of this type alone.
    pub fn text(&self) -> String {
        let mut out = String::new();
        for c in self.comments {
            out.push_str(&format!("# {c}\n"));
        }
        for f in self.fields {
            for c in f.comments {
                out.push_str(&format!("# {c}\n"));
            }
            out.push_str(&format!("{} {}", f.ty.ros_name(), f.name));
            if let Some(d) = f.default {
                out.push(' ');
                out.push_str(d);
            }
            out.push('\n');
        }
        out
    }

    /// The message types the fields use directly, in first-use order.
    pub fn deps(&self) -> Vec<&'static MsgDef> {
        let mut deps: Vec<&'static MsgDef> = Vec::new();
        for f in self.fields {
            if let Some(d) = f.ty.message() {
                if !deps.iter().any(|x| x.name == d.name) {
                    deps.push(d);
                }
            }
        }
        deps
    }

    /// The full schema text: this definition, then every dependency once, depth first.
    pub fn schema_text(&self) -> String {
        fn collect(d: &MsgDef, seen: &mut Vec<&'static str>, out: &mut String) {
            for dep in d.deps() {
                if !seen.contains(&dep.name) {
                    seen.push(dep.name);
                    out.push_str(&"=".repeat(80));
                    out.push_str("\nMSG: ");
                    out.push_str(dep.name);
                    out.push('\n');
                    out.push_str(&dep.text());
                    collect(dep, seen, out);
                }
            }
        }
        let mut out = self.text();
        let mut seen = vec![self.name];
        collect(self, &mut seen, &mut out);
        out
    }
}

/// A value that is one field of a message: its schema type and its CDR form.
pub trait RosField: Sized {
    /// The type as a schema declares it.
    const TYPE: FieldType;
    /// Appends the value to `w`.
    fn encode(&self, w: &mut CdrWriter);
    /// Reads the value from `r`.
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self>;
}

impl RosField for f64 {
    const TYPE: FieldType = FieldType::Primitive("float64");
    fn encode(&self, w: &mut CdrWriter) {
        w.f64(*self);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        r.f64()
    }
}

impl RosField for u32 {
    const TYPE: FieldType = FieldType::Primitive("uint32");
    fn encode(&self, w: &mut CdrWriter) {
        w.u32(*self);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        r.u32()
    }
}

impl RosField for i32 {
    const TYPE: FieldType = FieldType::Primitive("int32");
    fn encode(&self, w: &mut CdrWriter) {
        w.i32(*self);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        r.i32()
    }
}

impl RosField for bool {
    const TYPE: FieldType = FieldType::Primitive("bool");
    fn encode(&self, w: &mut CdrWriter) {
        w.u8(u8::from(*self));
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        match r.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(r.err(format!("bool byte {b}, expected 0 or 1"))),
        }
    }
}

impl RosField for String {
    const TYPE: FieldType = FieldType::Primitive("string");
    fn encode(&self, w: &mut CdrWriter) {
        w.string(self);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        r.string()
    }
}

impl<const N: usize> RosField for [f64; N] {
    const TYPE: FieldType = FieldType::Array(&FieldType::Primitive("float64"), N);
    fn encode(&self, w: &mut CdrWriter) {
        w.f64_array(self);
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        r.f64_array::<N>()
    }
}

impl<T: RosField> RosField for Vec<T> {
    const TYPE: FieldType = FieldType::Sequence(&T::TYPE);
    fn encode(&self, w: &mut CdrWriter) {
        w.seq_len(self.len());
        for x in self {
            x.encode(w);
        }
    }
    fn decode(r: &mut CdrReader<'_>) -> CdrResult<Self> {
        let n = r.seq_len()?;
        (0..n).map(|_| T::decode(r)).collect()
    }
}

/// A whole message: a [`RosField`] with a definition of its own.
pub trait RosMessage: RosField {
    /// Its definition.
    const DEF: &'static MsgDef;

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

/// Declares a ROS 2 message once: the struct, its [`MsgDef`] static, and its [`RosField`] and
/// [`RosMessage`] implementations.
///
/// ```ignore
/// ros_message! {
///     /// `geometry_msgs/Vector3`.
///     #[derive(Debug, Clone, Copy, PartialEq, Default)]
///     pub struct Vector3 (VECTOR3, "geometry_msgs/Vector3") {
///         /// x.
///         x: f64,
///         // a default value in the schema text, and a comment line above the field:
///         #[comment = "the w component"]
///         w: f64 = "1",
///     }
/// }
/// ```
macro_rules! ros_message {
    (
        $(#[$attr:meta])*
        pub struct $name:ident ($def:ident, $ros:literal) $(comment $mc:literal)* {
            $(
                $(#[doc = $fdoc:literal])*
                $(#[comment = $fc:literal])*
                $field:ident : $fty:ty $(= $default:literal)?
            ),* $(,)?
        }
    ) => {
        $(#[$attr])*
        pub struct $name {
            $(
                $(#[doc = $fdoc])*
                pub $field: $fty,
            )*
        }

        #[doc = concat!("Definition of `", $ros, "`.")]
        pub static $def: $crate::ros_msgs::MsgDef = $crate::ros_msgs::MsgDef {
            name: $ros,
            comments: &[$($mc),*],
            fields: &[$(
                $crate::ros_msgs::FieldDef {
                    name: stringify!($field),
                    ty: &<$fty as $crate::ros_msgs::RosField>::TYPE,
                    default: $crate::ros_msgs::ros_message!(@default $($default)?),
                    comments: &[$($fc),*],
                }
            ),*],
        };

        impl $crate::ros_msgs::RosField for $name {
            const TYPE: $crate::ros_msgs::FieldType = $crate::ros_msgs::FieldType::Message(&$def);
            fn encode(&self, w: &mut $crate::cdr::CdrWriter) {
                $( $crate::ros_msgs::RosField::encode(&self.$field, w); )*
            }
            fn decode(r: &mut $crate::cdr::CdrReader<'_>) -> $crate::cdr::CdrResult<Self> {
                Ok(Self {
                    $( $field: r.field(stringify!($field), <$fty as $crate::ros_msgs::RosField>::decode)?, )*
                })
            }
        }

        impl $crate::ros_msgs::RosMessage for $name {
            const DEF: &'static $crate::ros_msgs::MsgDef = &$def;
        }
    };
    (@default) => { None };
    (@default $d:literal) => { Some($d) };
}
pub(crate) use ros_message;

mod defs;

pub use defs::*;

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

    /// The generated texts are the ROS 2 definitions (comments stripped), as the hand-written
    /// ones were: a file written before the declarative definitions has the same schemas.
    #[test]
    fn generated_texts_are_the_ros2_definitions() {
        assert_eq!(
            QUATERNION.text(),
            "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"
        );
        assert_eq!(
            IMU.text(),
            "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n\
             float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n\
             float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n\
             float64[9] linear_acceleration_covariance\n"
        );
        assert_eq!(
            JOINT_STATE.text(),
            "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n\
             float64[] effort\n"
        );
        assert_eq!(TF_MESSAGE.text(), "geometry_msgs/TransformStamped[] transforms\n");
        assert_eq!(TIME.text(), "int32 sec\nuint32 nanosec\n");
        assert!(DRIVE_MARKER.text().starts_with(
            "# Where the DRIVE protocol is at one logged tick (drive-sim).\nstd_msgs/Header header\n"
        ));
    }

    /// The custom types ship as `.msg` files (a ROS 2 interface package under `msg/`) so ROS 2
    /// tools can build them; they must say exactly what the embedded schema says.
    #[test]
    fn shipped_msg_files_match_the_embedded_schemas() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../msg");
        // One custom type today; the loop is where a new one is added.
        #[allow(clippy::single_element_loop)]
        for def in [&DRIVE_MARKER] {
            let (pkg, name) = def.name.split_once('/').unwrap();
            let path = format!("{dir}/{pkg}/msg/{name}.msg");
            let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
            assert_eq!(text, def.text(), "{path} differs from the schema of {}", def.name);
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
            pose: PoseWithCovariance {
                pose: Pose {
                    position: Point {
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
                covariance: [0.25; 36],
            },
            twist: TwistWithCovariance {
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
                covariance: [0.0; 36],
            },
        };
        let b = o.to_cdr(Vec::new());
        // Header ends at 17; child_frame_id: pad to 20, length 20..24, "base_link\0" 24..34;
        // pad to 40, then 7 + 36 + 6 + 36 doubles.
        assert_eq!(b.len(), 4 + 40 + 8 * (7 + 36 + 6 + 36));
        assert_eq!(Odometry::from_cdr(&b).unwrap(), o);
        // Trailing garbage and a wrong type are refused; errors name the nested field.
        let mut longer = b.clone();
        longer.extend([0; 8]);
        assert!(Odometry::from_cdr(&longer).is_err());
        assert!(Imu::from_cdr(&b).is_err());
        let e = Odometry::from_cdr(&b[..60]).unwrap_err();
        assert!(e.field.starts_with("pose.pose."), "{e}");
    }

    #[test]
    fn std_msgs_scalars_round_trip() {
        for v in [0.0, -1.5, f64::MAX] {
            let m = Float64 { data: v };
            assert_eq!(Float64::from_cdr(&m.to_cdr(Vec::new())).unwrap(), m);
        }
        let m = Int32 { data: -7 };
        assert_eq!(m.to_cdr(Vec::new()), [0, 1, 0, 0, 0xf9, 0xff, 0xff, 0xff]);
        assert_eq!(Int32::from_cdr(&m.to_cdr(Vec::new())).unwrap(), m);
        let m = StringMsg { data: "calib".into() };
        assert_eq!(StringMsg::from_cdr(&m.to_cdr(Vec::new())).unwrap(), m);
        let m = Bool { data: true };
        assert_eq!(Bool::from_cdr(&m.to_cdr(Vec::new())).unwrap(), m);
        assert!(Bool::from_cdr(&[0, 1, 0, 0, 2]).is_err());
    }
}
