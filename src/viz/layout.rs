//! The default Rerun layout (blueprint) for watching a vehicle: on the left a view that
//! follows the AGV (its own frame, seen from straight above, forward up the screen) above
//! a top view of the whole travelled floor (x to the right, y up the screen, as the scene
//! defines them); on the right the time series, one quantity per plot, in three tabs so
//! that each plot is tall enough to read.
//!
//! The layout is built here rather than with the SDK's blueprint builder because the 3-D
//! views need their eyes placed (the builder has no eye setting), and it uses fixed ids,
//! so the same run writes the same layout.

use rerun::blueprint::components::{
    ColumnShare, ContainerKind, IncludedContent, PlayState, QueryExpression, RootContainer,
    RowShare, ViewClass,
};
use rerun::external::re_log_types::BlueprintActivationCommand;
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, EyeControls3D, TimePanelBlueprint, ViewBlueprint, ViewContents,
    ViewportBlueprint,
};
use rerun::{RecordingStream, RecordingStreamBuilder};

use super::{err, VizError};

/// Entity paths of the plots, with the view title (quantity and unit) each goes in.
pub const PLOTS: [(&str, &str); 7] = [
    (
        "plots/lateral_error_m",
        "Lateral error, m (sensor pair; left of the wire +)",
    ),
    (
        "plots/coils_adc",
        "Coil readings, ADC counts (red left, blue right)",
    ),
    (
        "plots/demand_pct",
        "DCMC demand, pct (grey forward, orange turn)",
    ),
    ("plots/voltage_V", "Motor voltage, V (red left, blue right)"),
    (
        "plots/motor_speed_rad_s",
        "Motor speed, rad/s (red left, blue right)",
    ),
    (
        "plots/slip_ratio",
        "Drive-tyre slip ratio (1: spins, vehicle still; red left, blue right)",
    ),
    (
        "plots/backlash_gap_rad",
        "Gear backlash gap, rad (red left, blue right)",
    ),
];

/// Height of the follow view's eye above the floor, m: the 1 m vehicle and its arrows
/// fill about half the view.
const FOLLOW_EYE_HEIGHT_M: f32 = 2.0;
/// Half the vertical field of view of Rerun's 3-D eye, rad (its default, about 55 deg).
const HALF_FOV_RAD: f64 = 0.48;
/// Width over height of the overview panel in the default layout.
const OVERVIEW_ASPECT: f64 = 2.2;

/// A fixed, valid (version 4) UUID per blueprint item.
pub(super) fn id(n: u8) -> [u8; 16] {
    [
        0xa6, 0x05, 0x1d, 0x00, 0, 0, 0x40, 0, 0x80, 0, 0, 0, 0, 0, 0, n,
    ]
}

fn hex(b: [u8; 16]) -> String {
    let h: String = b.iter().map(|x| format!("{x:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &h[0..8],
        &h[8..12],
        &h[12..16],
        &h[16..20],
        &h[20..32]
    )
}

fn view_path(n: u8) -> String {
    format!("view/{}", hex(id(n)))
}

fn container_path(n: u8) -> String {
    format!("container/{}", hex(id(n)))
}

/// Logs one view: class ("3D", "TimeSeries"), title, origin and content queries.
pub(super) fn view(
    bp: &RecordingStream,
    n: u8,
    class: &str,
    name: &str,
    origin: &str,
    contents: &[&str],
) -> Result<String, VizError> {
    let path = view_path(n);
    bp.log(
        format!("{path}/ViewContents"),
        &ViewContents::new(
            contents
                .iter()
                .map(|q| QueryExpression(q.to_string().into())),
        ),
    )
    .map_err(err)?;
    bp.log(
        path.as_str(),
        &ViewBlueprint::new(ViewClass(class.to_string().into()))
            .with_display_name(name)
            .with_space_origin(origin),
    )
    .map_err(err)?;
    Ok(path)
}

/// Places a 3-D view's eye: at `position`, looking at `target`, with `up` up the screen.
fn eye(
    bp: &RecordingStream,
    view: &str,
    position: [f32; 3],
    target: [f32; 3],
    up: [f32; 3],
) -> Result<(), VizError> {
    bp.log(
        format!("{view}/EyeControls3D"),
        &EyeControls3D::new()
            .with_position(position)
            .with_look_target(target)
            .with_eye_up(up),
    )
    .map_err(err)
}

pub(super) fn container(
    bp: &RecordingStream,
    n: u8,
    kind: ContainerKind,
    name: Option<&str>,
    children: &[String],
    shares: Option<&[f32]>,
) -> Result<String, VizError> {
    let path = container_path(n);
    let mut c = ContainerBlueprint::new(kind)
        .with_contents(children.iter().map(|c| IncludedContent(c.clone().into())));
    if let Some(name) = name {
        c = c.with_display_name(name);
    }
    match (kind, shares) {
        (ContainerKind::Grid, Some(s)) => {
            // A grid's "shares" is its column count.
            c = c.with_grid_columns(s.first().map_or(1, |v| *v as u32));
        }
        (ContainerKind::Horizontal, Some(s)) => {
            c = c.with_col_shares(s.iter().map(|v| ColumnShare((*v).into())));
        }
        (ContainerKind::Vertical, Some(s)) => {
            c = c.with_row_shares(s.iter().map(|v| RowShare((*v).into())));
        }
        _ => {}
    }
    bp.log(path.as_str(), &c).map_err(err)?;
    Ok(path)
}

/// Hides a time-series view's legend (the series are named elsewhere: a legend in a
/// narrow plot sits on the data).
pub(super) fn hide_legend(bp: &RecordingStream, view: &str) -> Result<(), VizError> {
    use rerun::external::re_sdk_types::blueprint::archetypes::PlotLegend;
    bp.log(
        format!("{view}/PlotLegend"),
        &PlotLegend::new().with_visible(false),
    )
    .map_err(err)
}

/// Builds a layout on a blueprint stream (`build` returns its root container's id) and
/// sends it to `rec` as its active and default layout.
pub(super) fn send_layout(
    rec: &RecordingStream,
    build: impl FnOnce(&RecordingStream) -> Result<u8, VizError>,
) -> Result<(), VizError> {
    let (bp, storage) = RecordingStreamBuilder::new("agvsim")
        .recording_id("agvsim-layout")
        .blueprint()
        .memory()
        .map_err(err)?;
    bp.set_time_sequence("blueprint", 0);
    let root = build(&bp)?;
    bp.log(
        "viewport",
        &ViewportBlueprint::new()
            .with_root_container(RootContainer(id(root).into()))
            .with_auto_layout(false)
            .with_auto_views(false),
    )
    .map_err(err)?;
    bp.flush_blocking().map_err(err)?;
    let msgs = storage.take();
    let Some(blueprint_id) = msgs.first().map(|m| m.store_id().clone()) else {
        return Err(VizError("the layout produced no messages".into()));
    };
    rec.send_blueprint(
        msgs,
        BlueprintActivationCommand {
            blueprint_id,
            make_active: true,
            make_default: true,
        },
    );
    Ok(())
}

/// Frames the overview on `region`: from above its centre, high enough that the view's
/// field takes it in with a tenth to spare (at least a metre each way).
fn overview_eye(bp: &RecordingStream, overview: &str, region: Region) -> Result<(), VizError> {
    let (lo, hi) = region;
    let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let half = (0.5 * (hi[1] - lo[1]))
        .max(0.5 * (hi[0] - lo[0]) / OVERVIEW_ASPECT)
        .max(1.0);
    let height = (1.1 * half / HALF_FOV_RAD.tan()) as f32;
    let c = [centre[0] as f32, centre[1] as f32];
    eye(
        bp,
        overview,
        [c[0], c[1], height],
        [c[0], c[1], 0.0],
        [0.0, 1.0, 0.0],
    )
}

/// The plots' tabs (tracking, drive, wheels), each a column of time series.
fn plot_tabs(bp: &RecordingStream) -> Result<Vec<String>, VizError> {
    let mut tabs = vec![];
    let groups: [(&str, &[usize]); 3] = [
        ("Tracking", &[0, 1]),
        ("Drive", &[2, 3, 4]),
        ("Wheels", &[5, 6]),
    ];
    for (g, (name, plots)) in groups.iter().enumerate() {
        let mut views = vec![];
        for &k in plots.iter() {
            let origin = format!("/{}", PLOTS[k].0);
            let plot = view(
                bp,
                10 + k as u8,
                "TimeSeries",
                PLOTS[k].1,
                &origin,
                &["$origin/**"],
            )?;
            // The title names the colours: a legend sat on the data.
            hide_legend(bp, &plot)?;
            views.push(plot);
        }
        tabs.push(container(
            bp,
            30 + g as u8,
            ContainerKind::Vertical,
            Some(name),
            &views,
            None,
        )?);
    }
    Ok(tabs)
}

/// The region of the floor the overview frames: (min, max) corners, world frame, m.
pub type Region = ([f64; 2], [f64; 2]);

/// Sends the layout to `rec`, the overview framed on `region` (the floor travelled, or
/// expected to be). Sent again with the travelled region when a run ends.
pub fn send_blueprint(rec: &RecordingStream, region: Region) -> Result<(), VizError> {
    send_layout(rec, |bp| {
        let follow = view(
            bp,
            1,
            "3D",
            "Vehicle, followed (its frame: forward up, left to the left)",
            "/world/agv",
            &["$origin/**"],
        )?;
        eye(
            bp,
            &follow,
            [0.3, 0.0, FOLLOW_EYE_HEIGHT_M],
            [0.3, 0.0, 0.0],
            [1.0, 0.0, 0.0],
        )?;
        let overview = view(
            bp,
            2,
            "3D",
            "Floor (world frame, m: x to the right, y up)",
            "/world",
            // The coil readings are the follow view's: on the floor their label would print
            // over the path wherever the vehicle is, cut off at the view's edge.
            &[
                "/world/**",
                "- /world/agv/nearby_wire",
                "- /world/agv/coils",
                "- /world/agv/coil_readings",
            ],
        )?;
        overview_eye(bp, &overview, region)?;
        let tabs = plot_tabs(bp)?;
        let legend = view(
            bp,
            3,
            "TextDocument",
            "What the vehicle view draws",
            "/legend",
            &["$origin"],
        )?;
        let left = container(
            bp,
            40,
            ContainerKind::Vertical,
            None,
            &[follow, legend, overview],
            Some(&[0.53, 0.14, 0.33]),
        )?;
        let right = container(bp, 41, ContainerKind::Tabs, None, &tabs, None)?;
        container(
            bp,
            42,
            ContainerKind::Horizontal,
            None,
            &[left, right],
            Some(&[0.55, 0.45]),
        )?;
        // The viewer opens at the latest moment logged: a saved run at its end, a live one
        // following the simulation; the time panel scrubs back.
        bp.log(
            "time_panel",
            &TimePanelBlueprint::new()
                .with_timeline("sim_time")
                .with_play_state(PlayState::Following),
        )
        .map_err(err)?;
        Ok(42)
    })
}
