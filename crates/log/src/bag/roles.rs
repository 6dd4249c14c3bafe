//! Topic roles: which topic of a bag carries the body command, each side's wheel speed, the
//! localisation odometry, the IMU and the protocol's step index and state.
//!
//! A roles TOML (format: `roles/warthog.toml`) maps each role to its topic(s) and message type.
//! The Warthog and Husky presets are the DRIVE node's own topics; without a preset that fits
//! the bag, roles are guessed from message types and topic names, and the guess is reported.

use super::storage::{normalize_type, Bag};
use drive_sim_model::error::{Error, Result};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// What a topic is used for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Role {
    /// Body command (`geometry_msgs/Twist`).
    Cmd,
    /// Left wheel speed, rad/s.
    WheelLeft,
    /// Right wheel speed, rad/s.
    WheelRight,
    /// Localisation odometry (pose, and the source's own twist).
    Odom,
    /// IMU.
    Imu,
    /// The protocol's step index.
    Step,
    /// The protocol's state (`idle`, `calib`).
    State,
}

impl Role {
    /// Every role, in report order.
    pub const ALL: [Role; 7] = [
        Role::Cmd,
        Role::WheelLeft,
        Role::WheelRight,
        Role::Odom,
        Role::Imu,
        Role::Step,
        Role::State,
    ];

    /// Key in a roles TOML.
    pub fn key(self) -> &'static str {
        match self {
            Role::Cmd => "cmd",
            Role::WheelLeft => "wheel_left",
            Role::WheelRight => "wheel_right",
            Role::Odom => "odom",
            Role::Imu => "imu",
            Role::Step => "step",
            Role::State => "state",
        }
    }

    /// Message types this reader decodes for the role.
    pub fn types(self) -> &'static [&'static str] {
        match self {
            Role::Cmd => &["geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"],
            Role::WheelLeft | Role::WheelRight => &["std_msgs/msg/Float64", "sensor_msgs/msg/JointState"],
            Role::Odom => &["nav_msgs/msg/Odometry"],
            Role::Imu => &["sensor_msgs/msg/Imu"],
            Role::Step => &["std_msgs/msg/Int32"],
            Role::State => &["std_msgs/msg/String"],
        }
    }

    /// Whether a log cannot be built without it: steps fall back to command constancy, and
    /// without an IMU the yaw rate comes from the pose.
    pub fn required(self) -> bool {
        !matches!(self, Role::Step | Role::State | Role::Imu)
    }

    fn from_key(k: &str) -> Option<Role> {
        Role::ALL.into_iter().find(|r| r.key() == k)
    }
}

/// One topic or a list of candidates.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
enum Topics {
    One(String),
    Many(Vec<String>),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RoleSpec {
    topic: Topics,
    #[serde(rename = "type")]
    msg_type: String,
    /// Joint name, for a `sensor_msgs/JointState` wheel topic.
    #[serde(default)]
    joint: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RolesFile {
    name: String,
    #[serde(default)]
    robot: Option<String>,
    roles: BTreeMap<String, RoleSpec>,
}

impl drive_sim_model::config::Validate for RolesFile {
    fn validate(&self) -> std::result::Result<(), (String, String)> {
        for (k, spec) in &self.roles {
            let empty = match &spec.topic {
                Topics::One(t) => t.is_empty(),
                Topics::Many(v) => v.is_empty() || v.iter().any(String::is_empty),
            };
            if empty {
                return Err((format!("roles.{k}.topic"), "empty topic name".into()));
            }
        }
        Ok(())
    }
}

/// A roles description: candidate topics and the expected type per role.
#[derive(Debug, Clone)]
pub struct RolesSpec {
    /// Preset or file name.
    pub name: String,
    /// Robot whose nominal values go with it, if any.
    pub robot: Option<String>,
    roles: BTreeMap<Role, (Vec<String>, String, Option<String>)>,
}

/// The presets: DRIVE node on the Warthog and on the Husky.
pub const PRESETS: [(&str, &str); 2] = [
    ("warthog", include_str!("../../../../roles/warthog.toml")),
    ("husky", include_str!("../../../../roles/husky.toml")),
];

impl RolesSpec {
    /// Parses a roles TOML; `origin` names it in errors.
    pub fn parse(text: &str, origin: &Path) -> Result<Self> {
        let f: RolesFile = drive_sim_model::config::parse_toml(text, origin)?;
        let mut roles = BTreeMap::new();
        for (k, spec) in f.roles {
            let role = Role::from_key(&k).ok_or_else(|| {
                let keys: Vec<&str> = Role::ALL.iter().map(|r| r.key()).collect();
                Error::config(
                    origin,
                    format!("roles.{k}"),
                    format!("unknown role; roles: {}", keys.join(", ")),
                )
            })?;
            let ty = normalize_type(&spec.msg_type);
            if !role.types().contains(&ty.as_str()) {
                return Err(Error::config(
                    origin,
                    format!("roles.{k}.type"),
                    format!(
                        "`{ty}` is not decoded for this role; expected {}",
                        role.types().join(" or ")
                    ),
                ));
            }
            let topics = match spec.topic {
                Topics::One(t) => vec![t],
                Topics::Many(v) => v,
            };
            roles.insert(role, (topics, ty, spec.joint));
        }
        Ok(Self {
            name: f.name,
            robot: f.robot,
            roles,
        })
    }

    /// A preset by name, or a file.
    pub fn resolve(name_or_path: &str) -> Result<Self> {
        if let Some((n, text)) = PRESETS.iter().find(|(n, _)| *n == name_or_path) {
            return Self::parse(text, Path::new(&format!("roles/{n}.toml")));
        }
        let p = Path::new(name_or_path);
        if p.is_file() {
            let text = std::fs::read_to_string(p).map_err(|e| Error::io(p, e))?;
            return Self::parse(&text, p);
        }
        Err(Error::Unknown {
            kind: "roles preset",
            name: name_or_path.to_string(),
            available: PRESETS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ") + " or a TOML file",
        })
    }
}

/// One resolved role.
#[derive(Debug, Clone, PartialEq)]
pub struct Assigned {
    /// Topic.
    pub topic: String,
    /// Its type, normalised.
    pub msg_type: String,
    /// Joint name for `JointState` wheel topics.
    pub joint: Option<String>,
}

/// Roles resolved against one bag.
#[derive(Debug, Clone)]
pub struct RoleMap {
    /// Where the roles come from: `preset warthog`, a file, or `guessed`.
    pub source: String,
    /// Robot of the preset, if any.
    pub robot: Option<String>,
    /// Resolved roles.
    pub roles: BTreeMap<Role, Assigned>,
    /// Roles with no topic in the bag, with what was looked for.
    pub missing: Vec<(Role, String)>,
    /// Roles guessed as the only topic of their type, their names matching no keyword.
    pub by_type_alone: Vec<Role>,
}

impl RoleMap {
    /// The missing required roles as one error, naming what was expected.
    pub fn check_required(&self, bag: &Path) -> Result<()> {
        let missing: Vec<String> = self
            .missing
            .iter()
            .filter(|(r, _)| r.required())
            .map(|(r, why)| format!("{} ({why})", r.key()))
            .collect();
        if missing.is_empty() {
            Ok(())
        } else {
            Err(Error::log(
                bag,
                "roles",
                format!(
                    "missing role(s) [{}] {}",
                    missing.join("; "),
                    self.source_phrase()
                ),
            ))
        }
    }

    /// A roles TOML (the format of `roles/warthog.toml`) that reads the bag with these roles,
    /// named `name`, ready to edit and pass with `--roles`; missing roles are commented out.
    pub fn to_toml(&self, name: &str) -> String {
        let q = |s: &str| format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""));
        let mut out = format!(
            "# Topic roles of this bag ({}): edit, then pass the file with --roles.\nname = {}\n",
            self.source,
            q(name)
        );
        match &self.robot {
            Some(r) => out += &format!("robot = {}\n", q(r)),
            None => out += "# robot = \"warthog\"\n",
        }
        for r in Role::ALL {
            out.push('\n');
            match self.roles.get(&r) {
                Some(a) => {
                    out += &format!(
                        "[roles.{}]\ntopic = {}\ntype = {}\n",
                        r.key(),
                        q(&a.topic),
                        q(&a.msg_type)
                    );
                    if let Some(j) = &a.joint {
                        out += &format!("joint = {}\n", q(j));
                    }
                }
                None => {
                    out += &format!(
                        "# [roles.{}]\n# topic = \"\"\n# type = {}\n",
                        r.key(),
                        q(r.types()[0])
                    );
                }
            }
        }
        out
    }

    /// Where the roles come from, as the end of a sentence.
    fn source_phrase(&self) -> String {
        if self.source.starts_with("guessed") {
            format!("with the roles {}", self.source)
        } else {
            format!("with the roles of {}", self.source)
        }
    }

    /// One line per role, for printing.
    pub fn describe(&self) -> Vec<String> {
        Role::ALL
            .iter()
            .map(
                |r| match (self.roles.get(r), self.missing.iter().find(|(m, _)| m == r)) {
                    (Some(a), _) if self.by_type_alone.contains(r) => format!(
                        "{:<11} {} ({}): the only topic of its type",
                        r.key(),
                        a.topic,
                        a.msg_type
                    ),
                    (Some(a), _) => format!("{:<11} {} ({})", r.key(), a.topic, a.msg_type),
                    (None, Some((_, why))) => format!(
                        "{:<11} MISSING{}: {why}",
                        r.key(),
                        if r.required() { "" } else { " (optional)" }
                    ),
                    (None, None) => format!("{:<11} -", r.key()),
                },
            )
            .collect()
    }
}

/// Applies `spec` to `bag`: the first candidate topic present per role; a present topic of the
/// wrong type is an error naming it.
pub fn apply(spec: &RolesSpec, bag: &Bag, source: String) -> Result<RoleMap> {
    let mut roles = BTreeMap::new();
    let mut missing = Vec::new();
    for (role, (topics, ty, joint)) in &spec.roles {
        match topics.iter().find_map(|t| bag.topic(t)) {
            Some(t) => {
                if &t.msg_type != ty {
                    return Err(Error::log(
                        &bag.path,
                        format!("topic {}", t.name),
                        format!(
                            "type {}, but role `{}` ({source}) expects {ty}",
                            t.msg_type,
                            role.key()
                        ),
                    ));
                }
                roles.insert(
                    *role,
                    Assigned {
                        topic: t.name.clone(),
                        msg_type: t.msg_type.clone(),
                        joint: joint.clone(),
                    },
                );
            }
            None => missing.push((
                *role,
                format!("no topic {} ({ty}) in the bag", topics.join(" or ")),
            )),
        }
    }
    for r in Role::ALL {
        if !spec.roles.contains_key(&r) {
            missing.push((r, format!("not in the roles of {source}")));
        }
    }
    Ok(RoleMap {
        source,
        robot: spec.robot.clone(),
        roles,
        missing,
        by_type_alone: Vec::new(),
    })
}

/// Name keywords that make a topic likely for a role (first = strongest), and words that rule
/// it out.
fn keywords(role: Role) -> (&'static [&'static str], &'static [&'static str]) {
    match role {
        Role::Cmd => (&["doughnut_cmd", "cmd_vel", "cmd"], &["joy", "teleop"]),
        Role::WheelLeft => (&["left"], &["current", "voltage", "cmd", "effort"]),
        Role::WheelRight => (&["right"], &["current", "voltage", "cmd", "effort"]),
        Role::Odom => (&["icp", "odom"], &["ground_truth", "truth"]),
        Role::Imu => (&["imu", "unbiased"], &[]),
        Role::Step => (&["calib_step", "step"], &[]),
        Role::State => (&["calib_state", "state"], &[]),
    }
}

/// Guesses the roles from types and names: per role, among the topics of its type not ruled
/// out by name nor taken by an earlier role, the one named most like it; without a name match,
/// the only such topic.
pub fn guess(bag: &Bag) -> RoleMap {
    let mut map = RoleMap {
        source: "guessed from types and names".into(),
        robot: None,
        roles: BTreeMap::new(),
        missing: Vec::new(),
        by_type_alone: Vec::new(),
    };
    for role in Role::ALL {
        let (good, bad) = keywords(role);
        let candidates: Vec<&super::storage::TopicInfo> = bag
            .topics
            .iter()
            .filter(|t| role.types().contains(&t.msg_type.as_str()))
            .filter(|t| !bad.iter().any(|b| t.name.to_lowercase().contains(b)))
            .filter(|t| !map.roles.values().any(|a| a.topic == t.name))
            .collect();
        let by_name = candidates
            .iter()
            .filter_map(|t| {
                let name = t.name.to_lowercase();
                let score = good.iter().position(|g| name.contains(g))?;
                Some((score, t.name.len(), *t))
            })
            .min_by_key(|(score, len, _)| (*score, *len))
            .map(|(_, _, t)| t);
        let alone = match candidates.as_slice() {
            [t] if by_name.is_none() => Some(*t),
            _ => None,
        };
        match by_name.or(alone) {
            Some(t) => {
                if alone.is_some() {
                    map.by_type_alone.push(role);
                }
                map.roles.insert(
                    role,
                    Assigned {
                        topic: t.name.clone(),
                        msg_type: t.msg_type.clone(),
                        joint: None,
                    },
                );
            }
            None => {
                let names: Vec<&str> = candidates.iter().map(|t| t.name.as_str()).collect();
                let listed = if names.is_empty() {
                    String::new()
                } else {
                    format!("; candidates: {}", names.join(", "))
                };
                map.missing.push((
                    role,
                    format!(
                        "no topic of type {} named like {}{listed}",
                        role.types().join(" or "),
                        good.join("/")
                    ),
                ));
            }
        }
    }
    map
}

/// The roles for `bag`: the given preset or file; else the first preset whose required topics
/// are all in the bag (the one named like `robot` first); else a guess.
pub fn choose(bag: &Bag, roles: Option<&str>, robot: Option<&str>) -> Result<RoleMap> {
    if let Some(r) = roles {
        let spec = RolesSpec::resolve(r)?;
        let source = format!("roles `{}`", spec.name);
        return apply(&spec, bag, source);
    }
    let mut order: Vec<&str> = PRESETS.iter().map(|(n, _)| *n).collect();
    if let Some(pos) = robot.and_then(|r| order.iter().position(|n| *n == r)) {
        let n = order.remove(pos);
        order.insert(0, n);
    }
    // A preset whose topic is there with another type: the error to report if nothing fits.
    let mut wrong_type = None;
    for name in order {
        let spec = RolesSpec::resolve(name)?;
        match apply(&spec, bag, format!("preset `{name}`")) {
            Ok(map) if map.missing.iter().all(|(r, _)| !r.required()) => return Ok(map),
            Ok(_) => {}
            Err(e) => {
                wrong_type.get_or_insert(e);
            }
        }
    }
    let g = guess(bag);
    match wrong_type {
        Some(e) if g.missing.iter().any(|(r, _)| r.required()) => Err(e),
        _ => Ok(g),
    }
}
