//! Frames waiting to be sent to Rerun as column chunks: one `send_columns` per entity
//! for many frames costs far less than a log call per entity per frame.

use rerun::RecordingStream;

use super::{err, VizError};

/// Frames of plot data sent together: columns cost far less than a log call per value per
/// frame, and each chunk carries its own schema, so larger batches also make smaller files.
/// A streaming viewer then updates every 5 s of simulated time at the default frame
/// interval: about 20 ms of wall time at the `full` level's speed.
pub(super) const PLOT_BATCH_FRAMES: usize = 250;

/// Frames waiting to be sent as column chunks: their times, the plot series (entity path,
/// values per frame, values) and the vehicle's moving parts. Everything under
/// `world/agv` is in the vehicle frame; `pose_*` places that frame on the floor.
#[derive(Default)]
pub(super) struct FrameBuffer {
    pub(super) times_s: Vec<f64>,
    pub(super) series: Vec<(&'static str, usize, Vec<f64>)>,
    /// The vehicle frame on the floor: axle midpoint, m, and heading, rad.
    pub(super) pose_xy: Vec<[f32; 3]>,
    pub(super) pose_heading_rad: Vec<f32>,
    /// 2 coils per frame: colour (positions are static in the vehicle frame); 1 label
    /// per frame with both readings, on a point ahead of the vehicle.
    pub(super) coil_colors: Vec<[u8; 4]>,
    pub(super) coil_labels: Vec<String>,
    /// Tyre force and slip arrows from the wheel contacts, vehicle frame, 2 per frame each.
    pub(super) contacts: Vec<[f32; 3]>,
    pub(super) force: Vec<[f32; 3]>,
    /// Slip arrows start beside the wheel, outboard: 2 per frame.
    pub(super) slip_origins: Vec<[f32; 3]>,
    pub(super) slip: Vec<[f32; 3]>,
    /// Slip arrow colours, 2 per frame: sliding beyond the friction peak or not.
    pub(super) slip_colors: Vec<[u8; 4]>,
    /// Castor forks, vehicle frame, `castors_per_frame` strips per frame.
    pub(super) castors: Vec<Vec<[f32; 3]>>,
    pub(super) castors_per_frame: usize,
    /// The wire near the vehicle, vehicle frame: strips per frame vary.
    pub(super) nearby_wire: Vec<Vec<[f32; 3]>>,
    pub(super) nearby_wire_per_frame: Vec<usize>,
    /// The swing-away strategy's assumed wire, world frame: a strip in the frames that
    /// have one.
    pub(super) assumed_wire: Vec<Vec<[f32; 3]>>,
    pub(super) assumed_wire_per_frame: Vec<usize>,
}

impl FrameBuffer {
    pub(super) fn push(&mut self, path: &'static str, values: &[f64]) {
        match self.series.iter_mut().find(|s| s.0 == path) {
            Some(s) => s.2.extend_from_slice(values),
            None => self.series.push((path, values.len(), values.to_vec())),
        }
    }

    pub(super) fn flush(&mut self, rec: &RecordingStream) -> Result<(), VizError> {
        if self.times_s.is_empty() {
            return Ok(());
        }
        let n = self.times_s.len();
        let times = || {
            [rerun::TimeColumn::new_duration_secs(
                "sim_time",
                self.times_s.iter().copied(),
            )]
        };
        for (path, width, values) in &mut self.series {
            let columns = rerun::Scalars::new(std::mem::take(values))
                .columns(std::iter::repeat_n(*width, n))
                .map_err(err)?;
            rec.send_columns(*path, times(), columns).map_err(err)?;
        }
        let per = |k: usize| std::iter::repeat_n(k, n);
        let rotations: Vec<rerun::RotationAxisAngle> = std::mem::take(&mut self.pose_heading_rad)
            .into_iter()
            .map(|h| rerun::RotationAxisAngle::new([0.0, 0.0, 1.0], rerun::Angle::from_radians(h)))
            .collect();
        let pose = rerun::Transform3D::update_fields()
            .with_many_translation(std::mem::take(&mut self.pose_xy))
            .with_many_rotation_axis_angle(rotations)
            .columns(per(1))
            .map_err(err)?;
        rec.send_columns("world/agv", times(), pose).map_err(err)?;
        let coils = rerun::Points3D::update_fields()
            .with_colors(std::mem::take(&mut self.coil_colors))
            .columns(per(2))
            .map_err(err)?;
        rec.send_columns("world/agv/coils", times(), coils)
            .map_err(err)?;
        let readings = rerun::Points3D::update_fields()
            .with_labels(std::mem::take(&mut self.coil_labels))
            .columns(per(1))
            .map_err(err)?;
        rec.send_columns("world/agv/coil_readings", times(), readings)
            .map_err(err)?;
        let contacts = std::mem::take(&mut self.contacts);
        let force = rerun::Arrows3D::from_vectors(std::mem::take(&mut self.force))
            .with_origins(contacts)
            .columns(per(2))
            .map_err(err)?;
        rec.send_columns("world/agv/tyre_force", times(), force)
            .map_err(err)?;
        let slip = rerun::Arrows3D::from_vectors(std::mem::take(&mut self.slip))
            .with_origins(std::mem::take(&mut self.slip_origins))
            .with_colors(std::mem::take(&mut self.slip_colors))
            .columns(per(2))
            .map_err(err)?;
        rec.send_columns("world/agv/slip", times(), slip)
            .map_err(err)?;
        if self.castors_per_frame > 0 {
            let k = self.castors_per_frame;
            let castors = rerun::LineStrips3D::update_fields()
                .with_strips(std::mem::take(&mut self.castors))
                .columns(per(k))
                .map_err(err)?;
            rec.send_columns("world/agv/castors", times(), castors)
                .map_err(err)?;
        }
        let lengths = std::mem::take(&mut self.nearby_wire_per_frame);
        let strips = rerun::LineStrips3D::update_fields()
            .with_strips(std::mem::take(&mut self.nearby_wire))
            .columns(lengths)
            .map_err(err)?;
        rec.send_columns("world/agv/nearby_wire", times(), strips)
            .map_err(err)?;
        let lengths = std::mem::take(&mut self.assumed_wire_per_frame);
        if lengths.iter().any(|&k| k > 0) {
            let assumed = rerun::LineStrips3D::update_fields()
                .with_strips(std::mem::take(&mut self.assumed_wire))
                .columns(lengths)
                .map_err(err)?;
            rec.send_columns("world/assumed_wire", times(), assumed)
                .map_err(err)?;
        }
        self.assumed_wire.clear();
        self.times_s.clear();
        Ok(())
    }
}
