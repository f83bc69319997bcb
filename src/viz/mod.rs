//! The Rerun recorder: an observer of snapshots that logs the floor scene and time series
//! at a decimated rate, with a default layout (blueprint) a newcomer can read: the floor
//! view on the left, four stacked plots on the right.
//!
//! The 2-D view draws y downwards, so world y is negated when logged: a left turn on the
//! floor looks like one on the screen.

use std::path::PathBuf;

use rerun::blueprint::{Blueprint, Horizontal, Spatial2DView, TimeSeriesView, Vertical};
use rerun::{RecordingStream, RecordingStreamBuilder};

use crate::sim::{SimParams, Snapshot};

mod frames;
mod reports;

use frames::{FrameBuffer, PLOT_BATCH_FRAMES};
pub use reports::{save_diagnosis, save_identification};

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

/// Errors from the Rerun SDK, as text (the SDK's error types differ per sink).
#[derive(Debug, thiserror::Error)]
#[error("rerun: {0}")]
pub struct VizError(pub String);

const GREY: [u8; 4] = [120, 120, 120, 255];
const WIRE: [u8; 4] = [255, 170, 0, 255];
const BODY: [u8; 4] = [80, 160, 255, 255];
const CASTOR: [u8; 4] = [200, 200, 200, 255];
const FORCE: [u8; 4] = [255, 80, 200, 255];
const SLIP: [u8; 4] = [255, 255, 0, 255];
const PATH: [u8; 4] = [120, 220, 120, 255];
/// The swing-away strategy's assumed wire.
const ASSUMED: [u8; 4] = [255, 255, 120, 255];
const LEFT: [u8; 4] = [230, 90, 90, 255];
const RIGHT: [u8; 4] = [90, 140, 230, 255];

fn w(p: [f64; 2]) -> [f32; 2] {
    [p[0] as f32, -p[1] as f32]
}

/// Logs snapshots to Rerun every `every` physics steps.
pub struct RerunRecorder {
    rec: RecordingStream,
    every: u64,
    count: u64,
    path: Vec<[f32; 2]>,
    path_every: u64,
    /// Travelled region (min, max), world frame, for framing the floor at the end.
    seen: ([f64; 2], [f64; 2]),
    wire: Vec<[f64; 2]>,
    wire_closed: bool,
    floor_name: &'static str,
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

/// The default layout.
pub fn blueprint() -> Blueprint {
    let floor = Spatial2DView::new("Floor (top view)").with_origin("/world");
    let tracking =
        TimeSeriesView::new("Tracking: lateral error (m)").with_origin("/plots/tracking");
    let sensors =
        TimeSeriesView::new("Guide-wire sensors (ADC counts)").with_origin("/plots/sensors");
    let drive =
        TimeSeriesView::new("DCMC: demand (pct) and motor voltage (V)").with_origin("/plots/drive");
    let motors = TimeSeriesView::new("Motor speed (rad/s)").with_origin("/plots/motors");
    let wheels =
        TimeSeriesView::new("Wheels: slip ratio, backlash gap (rad)").with_origin("/plots/wheels");
    Blueprint::new(
        Horizontal::new([
            floor.into(),
            Vertical::new([
                tracking.into(),
                sensors.into(),
                drive.into(),
                motors.into(),
                wheels.into(),
            ])
            .into(),
        ])
        .with_column_shares([0.55, 0.45]),
    )
}

impl RerunRecorder {
    /// Opens the target and logs the static scene (floor regions, wire, obstacles).
    pub fn new(
        target: &RerunTarget,
        name: &str,
        params: &SimParams,
        log_interval_s: f64,
    ) -> Result<Self, VizError> {
        let builder = RecordingStreamBuilder::new("agvsim")
            .recording_id(format!("agvsim-{name}-seed{}", params.seed))
            .with_blueprint(blueprint())
            .batcher_config(batcher_config());
        let rec = match target {
            RerunTarget::Save(p) => builder.save(p).map_err(err)?,
            RerunTarget::Spawn => builder.spawn().map_err(err)?,
            RerunTarget::Connect => builder.connect_grpc().map_err(err)?,
        };
        let every = ((log_interval_s / params.dt_s).round() as u64).max(1);
        let mut r = RerunRecorder {
            rec,
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
            frames: FrameBuffer::default(),
        };
        r.log_static(params)?;
        Ok(r)
    }

    fn log_static(&mut self, p: &SimParams) -> Result<(), VizError> {
        let rec = &self.rec;
        for (i, (_, surface, pts)) in p.floor.regions.iter().enumerate() {
            let mut strip: Vec<[f32; 2]> = pts.iter().map(|q| w(*q)).collect();
            strip.push(strip[0]);
            rec.log_static(
                format!("world/floor/region_{i}"),
                &rerun::LineStrips2D::new([strip])
                    .with_colors([[180, 140, 90, 255]])
                    .with_labels([surface.name]),
            )
            .map_err(err)?;
        }
        for (i, o) in p.obstacles.iter().enumerate() {
            let c = o.spec.center_m;
            let strip: Vec<[f32; 2]> = match (o.spec.half_extents_m, o.spec.radius_m) {
                (Some(h), _) => {
                    let (s, co) = o.spec.angle_rad.sin_cos();
                    let mut v: Vec<[f32; 2]> = [
                        [-1.0, -1.0],
                        [1.0, -1.0],
                        [1.0, 1.0],
                        [-1.0, 1.0],
                        [-1.0, -1.0],
                    ]
                    .iter()
                    .map(|k| {
                        let (x, y) = (k[0] * h[0], k[1] * h[1]);
                        w([c[0] + co * x - s * y, c[1] + s * x + co * y])
                    })
                    .collect();
                    v.shrink_to_fit();
                    v
                }
                (None, Some(r)) => (0..=32)
                    .map(|k| {
                        let a = k as f64 / 32.0 * std::f64::consts::TAU;
                        w([c[0] + r * a.cos(), c[1] + r * a.sin()])
                    })
                    .collect(),
                _ => continue,
            };
            rec.log_static(
                format!("world/obstacles/{i}"),
                &rerun::LineStrips2D::new([strip]).with_colors([[255, 60, 60, 255]]),
            )
            .map_err(err)?;
        }
        // The moving geometry's styles never change: logged once, static, so each frame
        // carries only positions (one colour or radius applies to every instance).
        rec.log_static(
            "world/agv/body",
            &rerun::LineStrips2D::update_fields().with_colors([BODY]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/coils",
            &rerun::Points2D::update_fields().with_radii([0.015f32]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/tyre_force",
            &rerun::Arrows2D::update_fields().with_colors([FORCE]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/slip",
            &rerun::Arrows2D::update_fields().with_colors([SLIP]),
        )
        .map_err(err)?;
        rec.log_static(
            "world/agv/castors",
            &rerun::LineStrips2D::update_fields()
                .with_colors([CASTOR])
                .with_radii([0.01f32]),
        )
        .map_err(err)?;
        if p.firmware.swing_away.is_some() {
            rec.log_static(
                "world/agv/assumed_wire",
                &rerun::LineStrips2D::update_fields()
                    .with_colors([ASSUMED])
                    .with_radii([0.004f32])
                    .with_labels(["assumed wire"]),
            )
            .map_err(err)?;
        }
        let series = |names: &[&str], colors: &[[u8; 4]]| {
            rerun::SeriesLines::new()
                .with_names(names.iter().map(|s| s.to_string()))
                .with_colors(colors.to_vec())
        };
        rec.log_static(
            "plots/tracking/lateral_error_m",
            &series(&["sensor pair off the wire (m)"], &[PATH]),
        )
        .map_err(err)?;
        rec.log_static(
            "plots/sensors/adc",
            &series(&["left coil", "right coil"], &[LEFT, RIGHT]),
        )
        .map_err(err)?;
        rec.log_static(
            "plots/drive/demand_pct",
            &series(
                &["forward demand (pct)", "turn demand (pct)"],
                &[GREY, WIRE],
            ),
        )
        .map_err(err)?;
        rec.log_static(
            "plots/drive/voltage_V",
            &series(&["left voltage (V)", "right voltage (V)"], &[LEFT, RIGHT]),
        )
        .map_err(err)?;
        rec.log_static(
            "plots/motors/motor_speed_rad_s",
            &series(
                &["left motor (rad/s)", "right motor (rad/s)"],
                &[[255, 150, 150, 255], [150, 190, 255, 255]],
            ),
        )
        .map_err(err)?;
        rec.log_static(
            "plots/wheels/slip_ratio",
            &series(&["left slip", "right slip"], &[LEFT, RIGHT]),
        )
        .map_err(err)?;
        rec.log_static(
            "plots/wheels/backlash_gap_rad",
            &series(
                &["left gap (rad)", "right gap (rad)"],
                &[[255, 200, 120, 255], [120, 220, 255, 255]],
            ),
        )
        .map_err(err)?;
        Ok(())
    }

    /// Called once per physics step: whether this step's snapshot is to be logged (every
    /// `every`-th step, from the first). The caller builds the snapshot only then.
    pub fn due(&mut self) -> bool {
        let due = self.count % self.every == 0;
        self.count += 1;
        due
    }

    /// Logs a snapshot of a step for which [`Self::due`] said yes.
    pub fn observe(&mut self, s: &Snapshot, p: &SimParams) -> Result<(), VizError> {
        let rec = &self.rec;
        rec.set_duration_secs("sim_time", s.t_s);
        let pose = s.pose;
        for k in 0..2 {
            let v = [pose.x_m, pose.y_m][k];
            self.seen.0[k] = self.seen.0[k].min(v);
            self.seen.1[k] = self.seen.1[k].max(v);
        }
        let (front, rear, width) = p.outline_m;
        let outline: Vec<[f32; 2]> = [
            [front, width / 2.0],
            [-rear, width / 2.0],
            [-rear, -width / 2.0],
            [front, -width / 2.0],
            [front, width / 2.0],
        ]
        .iter()
        .map(|q| w(pose.to_world(*q)))
        .collect();
        let nose = vec![
            w(pose.to_world([0.0, 0.0])),
            w(pose.to_world([front * 0.8, 0.0])),
        ];
        let b = &mut self.frames;
        b.body.push(outline);
        b.body.push(nose);
        for (k, c) in s.coils_m.iter().enumerate() {
            let v = s.sensors_adc[k];
            let level = (v / 255.0).clamp(0.0, 1.0);
            b.coils.push(w(*c));
            b.coil_colors
                .push([255, (255.0 * (1.0 - level)) as u8, 0, 255]);
            b.coil_labels
                .push(format!("{} {v:.0}", if k == 0 { "L" } else { "R" }));
        }
        // Tyre forces (N -> m at 1 mm/N) and slip (the sliding velocity direction).
        for x in &s.sides {
            b.contacts.push(w(x.contact_m));
            let f = pose.rotate(x.tyre_force_n);
            b.force.push([0.001 * f[0] as f32, -0.001 * f[1] as f32]);
            let v = pose.rotate([0.3 * x.slip_ratio, 0.3 * x.slip_angle_rad]);
            b.slip.push([v[0] as f32, -v[1] as f32]);
        }
        b.castors_per_frame = s.castors.len();
        match s.assumed_wire_m {
            Some([a, z]) => {
                b.assumed_wire.push(vec![w(a), w(z)]);
                b.assumed_wire_per_frame.push(1);
            }
            None => b.assumed_wire_per_frame.push(0),
        }
        for c in &s.castors {
            b.castors.push(vec![w(c.swivel_m), w(c.patch_m)]);
        }
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
            self.log_path()?;
        }
        let b = &mut self.frames;
        b.times_s.push(s.t_s);
        b.push("plots/tracking/lateral_error_m", &[s.lateral_error_m]);
        b.push("plots/sensors/adc", &s.sensors_adc);
        b.push("plots/drive/demand_pct", &s.demand_pct);
        b.push(
            "plots/drive/voltage_V",
            &[s.sides[0].voltage_v, s.sides[1].voltage_v],
        );
        b.push(
            "plots/motors/motor_speed_rad_s",
            &[s.sides[0].motor_speed_rad_s, s.sides[1].motor_speed_rad_s],
        );
        b.push(
            "plots/wheels/slip_ratio",
            &[s.sides[0].slip_ratio, s.sides[1].slip_ratio],
        );
        b.push(
            "plots/wheels/backlash_gap_rad",
            &[s.sides[0].backlash_gap_rad, s.sides[1].backlash_gap_rad],
        );
        if b.times_s.len() >= PLOT_BATCH_FRAMES {
            b.flush(rec)?;
        }
        Ok(())
    }

    /// Re-logs the travelled path, the whole strip (at the current time).
    fn log_path(&self) -> Result<(), VizError> {
        self.rec
            .log(
                "world/path",
                &rerun::LineStrips2D::new([self.path.clone()]).with_colors([PATH]),
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
        let floor = vec![w(lo), w([hi[0], lo[1]]), w(hi), w([lo[0], hi[1]]), w(lo)];
        self.rec
            .log_static(
                "world/floor",
                &rerun::LineStrips2D::new([floor])
                    .with_colors([GREY])
                    .with_labels([self.floor_name]),
            )
            .map_err(err)?;
        let mut pts = self.wire.clone();
        if self.wire_closed {
            pts.push(pts[0]);
        }
        let strips: Vec<Vec<[f32; 2]>> = pts
            .windows(2)
            .filter_map(|s| clip_segment(s[0], s[1], lo, hi))
            .map(|(a, b)| vec![w(a), w(b)])
            .collect();
        self.rec
            .log_static(
                "world/wire",
                &rerun::LineStrips2D::new(strips)
                    .with_colors([WIRE])
                    .with_radii([0.006f32]),
            )
            .map_err(err)?;
        self.rec.flush_blocking().map_err(err)
    }
}

/// The part of a segment inside an axis-aligned box (Liang-Barsky), if any.
fn clip_segment(
    a: [f64; 2],
    b: [f64; 2],
    lo: [f64; 2],
    hi: [f64; 2],
) -> Option<([f64; 2], [f64; 2])> {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        for (p, q) in [(-d[k], a[k] - lo[k]), (d[k], hi[k] - a[k])] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
    }
    (t0 <= t1).then(|| {
        (
            [a[0] + t0 * d[0], a[1] + t0 * d[1]],
            [a[0] + t1 * d[0], a[1] + t1 * d[1]],
        )
    })
}
