//! The kinds of machine a rig file or a recording describes (`rig = "..."`,
//! `# rig: ...`).

use std::fmt;

/// What machine a rig or recording is of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RigKind {
    /// One motor driving a load through a gear: a lifted wheel, a linear axis
    /// (`drive_axis`).
    DriveAxis,
    /// A differential-drive vehicle on the floor (`vehicle`).
    Vehicle,
    /// Two lifted drive axes behind the DCMC, the thesis's random-demand runs
    /// (`drive_pair`, an addition of this project).
    DrivePair,
    /// A velocity-commanded differential-drive base on the floor, a ROS robot: a vehicle
    /// whose base controller and drivers' speed loops take `cmd_vel` (`base`, an addition
    /// of this project; a rig kind only: its recordings are `vehicle` recordings).
    Base,
}

impl RigKind {
    /// Every kind, in the order messages list them.
    pub const ALL: [RigKind; 4] = [
        RigKind::DriveAxis,
        RigKind::Vehicle,
        RigKind::DrivePair,
        RigKind::Base,
    ];

    /// The name files use.
    pub fn as_str(self) -> &'static str {
        match self {
            RigKind::DriveAxis => "drive_axis",
            RigKind::Vehicle => "vehicle",
            RigKind::DrivePair => "drive_pair",
            RigKind::Base => "base",
        }
    }

    /// The kind a file names, if it is one.
    pub fn from_name(name: &str) -> Option<RigKind> {
        RigKind::ALL.into_iter().find(|k| k.as_str() == name)
    }

    /// The names, comma-separated, for messages.
    pub fn names() -> String {
        RigKind::ALL.map(RigKind::as_str).join(", ")
    }
}

impl fmt::Display for RigKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_reads_back_from_its_name_and_nothing_else_does() {
        for k in RigKind::ALL {
            assert_eq!(RigKind::from_name(k.as_str()), Some(k));
        }
        assert_eq!(RigKind::from_name("Vehicle"), None);
        assert_eq!(RigKind::names(), "drive_axis, vehicle, drive_pair, base");
    }
}
