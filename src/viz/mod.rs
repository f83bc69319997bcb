//! The Rerun recorder: an observer of snapshots that logs the floor scene and time series
//! at a decimated rate, with a default layout (blueprint, `layout.rs`) a newcomer can read.
//!
//! Everything is logged in 3-D on the floor plane (z = 0, z up), so the viewer shows and
//! reads coordinates exactly as the scene defines them: x and y in metres, counter-
//! clockwise headings. The vehicle's parts are logged once in its own frame
//! (`world/agv`), whose pose is logged every frame: the follow view sits in that frame.

use std::path::PathBuf;

use rerun::{RecordingStream, RecordingStreamBuilder};

use crate::sim::{SimParams, Snapshot};

mod frames;
mod layout;
mod overlay;
mod reports;
mod shapes;

use frames::{FrameBuffer, PLOT_BATCH_FRAMES};
pub use layout::send_blueprint;
pub use reports::{save_calibration, save_diagnosis, save_identification, save_replay};
use shapes::{above_path, clip_segment, force_arrow, rectangle, slip_arrow, w};

/// Where the recording goes.
#[derive(Debug, Clone)]
pub enum RerunTarget {
    /// Write an `.rrd` file.
    Save(PathBuf),
    /// Start the viewer (the `rerun` binary on PATH) and stream to it.
    Spawn,
    /// Stream to a running viewer (default address).
    Connect,
}

/// How long `--connect` waits for the viewer's port to answer.
const CONNECT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(2);

/// Checks that a viewer listens on the SDK's default address before streaming to it: the
/// SDK would otherwise buffer the whole run and wait at its end, saying nothing.
fn viewer_listening() -> Result<(), VizError> {
    let addr = std::net::SocketAddr::from(([127, 0, 0, 1], rerun::DEFAULT_SERVER_PORT));
    std::net::TcpStream::connect_timeout(&addr, CONNECT_TIMEOUT)
        .map(|_| ())
        .map_err(|e| {
            VizError(format!(
                "--connect: no Rerun viewer answers at {addr} ({e}); start one with `rerun` (pip install rerun-sdk==0.36.3), or use --spawn to start it, or --save FILE.rrd"
            ))
        })
}

/// Errors from the Rerun SDK, as text (the SDK's error types differ per sink).
#[derive(Debug, thiserror::Error)]
#[error("rerun: {0}")]
pub struct VizError(pub String);

const GREY: [u8; 4] = [120, 120, 120, 255];
const WIRE: [u8; 4] = [255, 170, 0, 255];
const BODY: [u8; 4] = [80, 160, 255, 255];
const WHEEL: [u8; 4] = [230, 230, 230, 255];
const CASTOR: [u8; 4] = [200, 200, 200, 255];
const FORCE: [u8; 4] = [255, 80, 200, 255];
const SLIP: [u8; 4] = [255, 255, 0, 255];
const PATH: [u8; 4] = [120, 220, 120, 255];
/// The swing-away strategy's assumed wire.
const ASSUMED: [u8; 4] = [255, 255, 120, 255];
const LEFT: [u8; 4] = [230, 90, 90, 255];
const RIGHT: [u8; 4] = [90, 140, 230, 255];

/// Tyre-force arrows are [`FORCE_ARROW_M`] times the square root of the force over this,
/// N: a drive tyre at its grip limit on painted concrete (about 400 N) draws 1 m, as long
/// as the vehicle, and the few newtons of steady rolling still draw a visible 0.1 m (a
/// linear scale left them as invisible stubs).
pub const FORCE_ARROW_REF_N: f64 = 400.0;
/// Length of a force arrow at [`FORCE_ARROW_REF_N`], m.
pub const FORCE_ARROW_M: f64 = 1.0;
/// Slip arrows start this far outboard of the wheel, m: a sliding tyre's force and slip
/// point along one line, and drawn from one point they hid each other.
const SLIP_ARROW_OUTBOARD_M: f64 = 0.08;
/// The coil readings' label sits this far ahead of the body's front, m: on the coils it
/// covered the front castors.
const COIL_LABEL_AHEAD_M: f64 = 0.15;
/// Slip arrows: the slip vector (ratio forward, angle in rad sideways) drawn along itself
/// with a length of this many metres times the square root of its size: a rolling tyre's
/// 1 % draws 0.1 m and is seen, a spinning wheel's 100 % draws 1 m and stays on screen.
pub const SLIP_ARROW_M: f64 = 1.0;
/// Slip arrow colour when the tyre slides beyond its friction peak.
const SLIDING: [u8; 4] = [255, 60, 40, 255];
/// The travelled path's and the wire's widths, UI points: the path wider and below, the
/// wire narrower and above (it ran hidden under a path that follows it), both visible at
/// any zoom.
const PATH_UI_POINTS: f32 = 3.0;
const WIRE_UI_POINTS: f32 = 1.2;
/// Height of the wire above the floor in the views, m, so that it draws over the path.
const WIRE_ABOVE_PATH_M: f32 = 0.01;

/// Half the side of the square around the axle in which the follow view shows the wire, m.
const NEARBY_WIRE_HALF_M: f64 = 2.5;

/// Logs snapshots to Rerun every `every` physics steps.
pub struct RerunRecorder {
    rec: RecordingStream,
    /// A saved file is written under a temporary name and takes its own when the run
    /// ends: a run stopped half-way leaves no truncated `.rrd` that looks finished.
    save_as: Option<(std::path::PathBuf, std::path::PathBuf)>,
    every: u64,
    count: u64,
    path: Vec<[f32; 3]>,
    path_every: u64,
    /// Travelled region (min, max), world frame, for framing the floor at the end.
    seen: ([f64; 2], [f64; 2]),
    wire: Vec<[f64; 2]>,
    wire_closed: bool,
    floor_name: &'static str,
    /// Drive-wheel contact points, vehicle frame (the arrows' origins).
    contacts: [[f32; 3]; 2],
    /// Frames (plots and moving geometry) waiting to be sent as column chunks.
    frames: FrameBuffer,
}

/// Frames between re-logs of the travelled path (the whole strip each time).
const PATH_LOG_EVERY_FRAMES: u64 = 25;

/// The SDK's batcher sends what it holds every `flush_tick`; its default (200 ms) is longer
/// than a whole typical run, so all the encoding and compression would wait for `finish`
/// and add to the run's time. A short tick lets the sink's thread encode on the other core
/// while the simulation runs.
fn batcher_config() -> rerun::log::ChunkBatcherConfig {
    rerun::log::ChunkBatcherConfig {
        flush_tick: std::time::Duration::from_millis(10),
        ..rerun::log::ChunkBatcherConfig::DEFAULT
    }
}

fn err(e: impl std::fmt::Display) -> VizError {
    VizError(e.to_string())
}

impl RerunRecorder {
    /// Opens the target and logs the static scene (floor regions, obstacles, the vehicle's
    /// body, wheels and coil positions in its own frame).
    pub fn new(
        target: &RerunTarget,
        name: &str,
        params: &SimParams,
        log_interval_s: f64,
    ) -> Result<Self, VizError> {
        let builder = RecordingStreamBuilder::new("agvsim")
            .recording_id(format!("agvsim-{name}-seed{}", params.sim.seed))
            .batcher_config(batcher_config());
        let mut save_as = None;
        let rec = match target {
            RerunTarget::Save(p) => {
                let tmp = crate::output::partial_name(p);
                save_as = Some((tmp.clone(), p.clone()));
                builder.save(&tmp).map_err(err)?
            }
            RerunTarget::Spawn => builder.spawn().map_err(err)?,
            RerunTarget::Connect => {
                viewer_listening()?;
                builder.connect_grpc().map_err(err)?
            }
        };
        // Named after the scene in the viewer's sources panel (a fixed recording id keeps
        // the builder from sending the name itself).
        rec.send_recording_name(name).map_err(err)?;
        // The overview first frames the floor around the start; the layout is sent again
        // with the travelled region when the run ends.
        let (x, y) = (params.start.x_m, params.start.y_m);
        send_blueprint(&rec, ([x - 5.0, y - 3.0], [x + 5.0, y + 3.0]))?;
        let every = ((log_interval_s / params.sim.dt_s).round() as u64).max(1);
        let mut r = RerunRecorder {
            rec,
            save_as,
            every,
            count: 0,
            path: Vec::new(),
            path_every: 5,
            seen: (
                [params.start.x_m, params.start.y_m],
                [params.start.x_m, params.start.y_m],
            ),
            wire: params.wire.points().to_vec(),
            wire_closed: params.wire.is_closed(),
            floor_name: params.floor.default.name,
            contacts: params.chassis.wheel_points_m().map(w),
            frames: FrameBuffer::default(),
        };
        r.log_static(params)?;
        Ok(r)
    }

    fn log_static(&mut self, p: &SimParams) -> Result<(), VizError> {
        let rec = &self.rec;
        rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())
            .map_err(err)?;
        for (i, (_, surface, pts)) in p.floor.regions.iter().enumerate() {
            let mut strip: Vec<[f32; 3]> = pts.iter().map(|q| w(*q)).collect();
            strip.push(strip[0]);
            rec.log_static(
                format!("world/floor/region_{i}"),
                &rerun::LineStrips3D::new([strip])
                    .with_colors([[180, 140, 90, 255]])
                    .with_labels([surface.name]),
            )
            .map_err(err)?;
        }
        self.log_obstacles(p)?;
        self.log_vehicle(p)?;
        self.log_plot_styles()
    }

    fn log_obstacles(&self, p: &SimParams) -> Result<(), VizError> {
        for (i, o) in p.obstacles.iter().enumerate() {
            let c = o.params.center_m;
            let strip: Vec<[f32; 3]> = match (o.params.half_extents_m, o.params.radius_m) {
                (Some(h), _) => rectangle(c, h, o.params.angle_rad),
                (None, Some(r)) => (0..=32)
                    .map(|k| {
                        let a = k as f64 / 32.0 * std::f64::consts::TAU;
                        w([c[0] + r * a.cos(), c[1] + r * a.sin()])
                    })
                    .collect(),
                _ => continue,
            };
            self.rec
                .log_static(
                    format!("world/obstacles/{i}"),
                    &rerun::LineStrips3D::new([strip]).with_colors([[255, 60, 60, 255]]),
                )
                .map_err(err)?;
        }
        Ok(())
    }

    /// The vehicle in its own frame: body outline with a nose line, the two drive wheels
    /// (they do not steer), coil positions, and the styles and origins of the arrows.
    fn log_vehicle(&self, p: &SimParams) -> Result<(), VizError> {
        let rec = &self.rec;
        let (front, rear, width) = p.outline_m();
        let outline = rectangle(
            [0.5 * (front - rear), 0.0],
            [0.5 * (front + rear), 0.5 * width],
            0.0,
        );
        let nose = vec![w([0.0, 0.0]), w([front * 0.8, 0.0])];
        rec.log_static(
            "world/agv/body",
            &rerun::LineStrips3D::new([outline, nose]).with_colors([BODY]),
        )
        .map_err(err)?;
        let r = p.drivetrain.wheel.radius_m;
        let wheels: Vec<Vec<[f32; 3]>> = p
            .chassis
            .wheel_points_m()
            .iter()
            .map(|c| rectangle(*c, [r, 0.025], 0.0))
            .collect();
        rec.log_static(
            "world/agv/wheels",
            &rerun::LineStrips3D::new(wheels)
                .with_colors([WHEEL])
                .with_radii([0.008f32]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/coils",
            &rerun::Points3D::new(p.coils_m().iter().map(|c| w(*c))).with_radii([0.02f32]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/coil_readings",
            &rerun::Points3D::new([w([front + COIL_LABEL_AHEAD_M, 0.0])])
                .with_radii([0.005f32])
                .with_colors([WIRE]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/tyre_force",
            &rerun::Arrows3D::update_fields()
                .with_colors([FORCE])
                .with_radii([0.008f32]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/slip",
            &rerun::Arrows3D::update_fields().with_radii([0.012f32]),
        )
        .map_err(err)?;
        self.log_legend()?;
        rec.log_static(
            "world/agv/castors",
            &rerun::LineStrips3D::update_fields()
                .with_colors([CASTOR])
                .with_radii([0.01f32]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/nearby_wire",
            &rerun::LineStrips3D::update_fields()
                .with_colors([WIRE])
                .with_radii([rerun::Radius::new_ui_points(WIRE_UI_POINTS)]),
        )
        .map_err(err)?;
        if p.firmware.swing_away.is_some() {
            rec.log_static(
                "world/assumed_wire",
                &rerun::LineStrips3D::update_fields()
                    .with_colors([ASSUMED])
                    .with_radii([0.004f32])
                    .with_labels(["assumed wire"]),
            )
            .map_err(err)?;
        }
        Ok(())
    }

    /// What the vehicle view draws and at what scale, as a text the layout shows under it:
    /// labels on the arrows themselves would print over each other whenever the arrows
    /// are short, and at the view's edge be cut off.
    fn log_legend(&self) -> Result<(), VizError> {
        let text = format!(
            "**Magenta**: tyre force, {FORCE_ARROW_M} m x sqrt(F / {:.0} N). **Yellow** (**red**: \
             sliding): slip, beside the wheel, {SLIP_ARROW_M} m x sqrt(slip). **Orange**: the \
             wire, over the green path. Label ahead: coils, ADC counts.",
            FORCE_ARROW_REF_N
        );
        self.rec
            .log_static(
                "legend",
                &rerun::TextDocument::new(text).with_media_type(rerun::MediaType::markdown()),
            )
            .map_err(err)
    }

    /// Series names and colours: one quantity per plot, named by side.
    fn log_plot_styles(&self) -> Result<(), VizError> {
        let series = |names: &[&str], colors: &[[u8; 4]]| {
            rerun::SeriesLines::new()
                .with_names(names.iter().map(|s| s.to_string()))
                .with_colors(colors.to_vec())
        };
        let sides = series(&["left", "right"], &[LEFT, RIGHT]);
        for (path, _) in layout::PLOTS {
            let style = match path {
                "plots/lateral_error_m" => series(&["sensor pair"], &[PATH]),
                "plots/demand_pct" => series(&["forward", "turn"], &[GREY, WIRE]),
                _ => sides.clone(),
            };
            self.rec.log_static(path, &style).map_err(err)?;
        }
        Ok(())
    }

    /// Called once per physics step: whether this step's snapshot is to be logged (every
    /// `every`-th step, from the first). The caller builds the snapshot only then.
    pub fn due(&mut self) -> bool {
        let due = self.count.is_multiple_of(self.every);
        self.count += 1;
        due
    }

    /// Logs a snapshot of a step for which [`Self::due`] said yes.
    pub fn observe(&mut self, s: &Snapshot, _p: &SimParams) -> Result<(), VizError> {
        let pose = s.pose;
        for k in 0..2 {
            let v = [pose.x_m, pose.y_m][k];
            self.seen.0[k] = self.seen.0[k].min(v);
            self.seen.1[k] = self.seen.1[k].max(v);
        }
        self.buffer_vehicle(s);
        let b = &mut self.frames;
        b.times_s.push(s.t_s);
        b.push("plots/lateral_error_m", &[s.lateral_error_m]);
        b.push("plots/coils_adc", &s.sensors_adc);
        b.push("plots/demand_pct", &s.demand_pct);
        b.push(
            "plots/voltage_V",
            &[s.sides[0].voltage_v, s.sides[1].voltage_v],
        );
        b.push(
            "plots/motor_speed_rad_s",
            &[s.sides[0].motor_speed_rad_s, s.sides[1].motor_speed_rad_s],
        );
        b.push(
            "plots/slip_ratio",
            &[s.sides[0].slip_ratio, s.sides[1].slip_ratio],
        );
        b.push(
            "plots/backlash_gap_rad",
            &[s.sides[0].backlash_gap_rad, s.sides[1].backlash_gap_rad],
        );
        let frame = self.count / self.every;
        if frame % self.path_every == 1 || self.path.is_empty() {
            self.path.push(w([pose.x_m, pose.y_m]));
            if self.path.len() > 4000 {
                // Thin the trace rather than grow without bound.
                self.path = self.path.iter().step_by(2).cloned().collect();
                self.path_every *= 2;
            }
        }
        if frame % PATH_LOG_EVERY_FRAMES == 1 || self.path.len() == 1 {
            self.rec.set_duration_secs("sim_time", s.t_s);
            self.log_path()?;
        }
        if self.frames.times_s.len() >= PLOT_BATCH_FRAMES {
            self.frames.flush(&self.rec)?;
        }
        Ok(())
    }

    /// The vehicle's moving parts for one frame, in its own frame.
    fn buffer_vehicle(&mut self, s: &Snapshot) {
        let pose = s.pose;
        let in_body = |p: [f64; 2]| pose.unrotate([p[0] - pose.x_m, p[1] - pose.y_m]);
        let body = |p: [f64; 2]| w(in_body(p));
        let b = &mut self.frames;
        b.pose_xy.push(w([pose.x_m, pose.y_m]));
        b.pose_heading_rad.push(pose.heading_rad as f32);
        // The coils sit 74 mm apart: one label on the left coil carries both readings.
        for k in 0..2 {
            let v = s.sensors_adc[k];
            let level = (v / 255.0).clamp(0.0, 1.0);
            b.coil_colors
                .push([255, (255.0 * (1.0 - level)) as u8, 0, 255]);
        }
        b.coil_labels.push(format!(
            "coils L {:.0} R {:.0}",
            s.sensors_adc[0], s.sensors_adc[1]
        ));
        // The wheels do not steer: wheel-frame forces and slips are body-frame vectors.
        for (x, c) in s.sides.iter().zip(self.contacts) {
            b.contacts.push(c);
            b.force.push(force_arrow(x.tyre_force_n));
            b.slip_origins.push([
                c[0],
                c[1] + (SLIP_ARROW_OUTBOARD_M as f32).copysign(c[1]),
                c[2],
            ]);
            b.slip.push(slip_arrow(x.slip_ratio, x.slip_angle_rad));
            b.slip_colors.push(if x.sliding { SLIDING } else { SLIP });
        }
        b.castors_per_frame = s.castors.len();
        for c in &s.castors {
            b.castors.push(vec![body(c.swivel_m), body(c.patch_m)]);
        }
        let h = NEARBY_WIRE_HALF_M;
        let (lo, hi) = ([pose.x_m - h, pose.y_m - h], [pose.x_m + h, pose.y_m + h]);
        let mut pts = self.wire.clone();
        if self.wire_closed {
            pts.push(pts[0]);
        }
        let before = b.nearby_wire.len();
        for seg in pts.windows(2) {
            if let Some((a, z)) = clip_segment(seg[0], seg[1], lo, hi) {
                b.nearby_wire
                    .push(vec![above_path(in_body(a)), above_path(in_body(z))]);
            }
        }
        b.nearby_wire_per_frame.push(b.nearby_wire.len() - before);
        match s.assumed_wire_m {
            Some([a, z]) => {
                b.assumed_wire.push(vec![w(a), w(z)]);
                b.assumed_wire_per_frame.push(1);
            }
            None => b.assumed_wire_per_frame.push(0),
        }
    }

    /// Re-logs the travelled path, the whole strip (at the current time).
    fn log_path(&self) -> Result<(), VizError> {
        self.rec
            .log(
                "world/path",
                &rerun::LineStrips3D::new([self.path.clone()])
                    .with_colors([PATH])
                    .with_radii([rerun::Radius::new_ui_points(PATH_UI_POINTS)]),
            )
            .map_err(err)
    }

    /// Logs the floor and the wire, framed on the travelled region (a long wire would
    /// otherwise shrink the vehicle to a dot), and flushes everything to the sink.
    pub fn finish(mut self) -> Result<(), VizError> {
        self.frames.flush(&self.rec)?;
        if !self.path.is_empty() {
            self.log_path()?;
        }
        let margin = 1.0;
        let lo = [self.seen.0[0] - margin, self.seen.0[1] - margin];
        let hi = [self.seen.1[0] + margin, self.seen.1[1] + margin];
        send_blueprint(&self.rec, (lo, hi))?;
        let floor = vec![w(lo), w([hi[0], lo[1]]), w(hi), w([lo[0], hi[1]]), w(lo)];
        self.rec
            .log_static(
                "world/floor",
                &rerun::LineStrips3D::new([floor])
                    .with_colors([GREY])
                    .with_labels([self.floor_name]),
            )
            .map_err(err)?;
        let mut pts = self.wire.clone();
        if self.wire_closed {
            pts.push(pts[0]);
        }
        let strips: Vec<Vec<[f32; 3]>> = pts
            .windows(2)
            .filter_map(|s| clip_segment(s[0], s[1], lo, hi))
            .map(|(a, b)| vec![above_path(a), above_path(b)])
            .collect();
        self.rec
            .log_static(
                "world/wire",
                &rerun::LineStrips3D::new(strips)
                    .with_colors([WIRE])
                    .with_radii([rerun::Radius::new_ui_points(WIRE_UI_POINTS)]),
            )
            .map_err(err)?;
        let RerunRecorder { rec, save_as, .. } = self;
        rec.flush_blocking().map_err(err)?;
        drop(rec);
        if let Some((tmp, path)) = save_as {
            std::fs::rename(&tmp, &path).map_err(|e| err(format!("{}: {e}", path.display())))?;
        }
        Ok(())
    }
}

impl crate::run::Watcher for RerunRecorder {
    fn due(&mut self) -> bool {
        RerunRecorder::due(self)
    }

    fn observe(&mut self, s: &Snapshot, params: &SimParams) -> Result<(), crate::run::WatchError> {
        RerunRecorder::observe(self, s, params).map_err(Into::into)
    }
}
