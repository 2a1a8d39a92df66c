//! PNG figures for `lobefit plot`: heat maps with colour bars and line charts.
//!
//! plotters is built without its default features, so no system fontconfig or
//! freetype is needed: text is drawn by ab_glyph with the bundled DejaVu Sans
//! (`assets/fonts`, Bitstream Vera licence). Files are written atomically (a
//! temporary `.png` in the same directory, then a rename).

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use plotters::style::FontStyle;

static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bundled font is a valid TrueType file; a failure here is a build defect.
        if plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_err() {
            panic!("bundled DejaVu Sans failed to parse");
        }
    });
}

/// One heat-map panel: `values[iy * nx + ix]` is the value at the centre of cell
/// (ix, iy); cells tile `x_range × y_range` uniformly (so plot in the coordinate you
/// sampled uniformly in, e.g. log10 e, and say so in the label).
#[derive(Debug, Clone)]
pub struct Heatmap {
    /// Panel title.
    pub title: String,
    /// Horizontal axis label (with unit or mapping).
    pub x_label: String,
    /// Vertical axis label.
    pub y_label: String,
    /// Horizontal extent of the cells.
    pub x_range: (f64, f64),
    /// Vertical extent of the cells.
    pub y_range: (f64, f64),
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Row-major values, y outer. Non-finite cells are drawn grey.
    pub values: Vec<f64>,
    /// Colour-bar label.
    pub colour_label: String,
    /// Colour by log10 of the value (non-positive values are drawn grey).
    pub log_colour: bool,
    /// Which colours over which range ([`ColourScale::Own`]: viridis over the panel's
    /// own minimum to maximum).
    pub scale: ColourScale,
}

/// The colour map of a [`Heatmap`] and the range it spans. Ranges are in the plotted
/// coordinate: log10 of the value when `log_colour` is set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ColourScale {
    /// Viridis from the panel's smallest to its largest finite value.
    Own,
    /// Viridis over `[lo, hi]`, values beyond drawn in the end colours: panels shown
    /// side by side for comparison take one range, so a colour means one value in
    /// each. `hi <= lo` or a non-finite end falls back to [`ColourScale::Own`].
    Fixed {
        /// Value drawn in the dark end.
        lo: f64,
        /// Value drawn in the bright end.
        hi: f64,
    },
    /// A diverging blue–white–red map ([`diverging_colour`]) over
    /// `[−limit, +limit]`: 0 white, negative values blue, positive red, values beyond
    /// ±limit drawn in the end colours (for signed errors; the caller states the limit
    /// in the title or colour label). A `limit` that is not finite and > 0 (an
    /// all-zero map) is taken as 1.
    Diverging {
        /// The symmetric limit (> 0).
        limit: f64,
    },
}

/// One polyline of a [`LineChart`].
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points (x, y); non-finite points (and non-positive ones on a log axis) are skipped.
    pub points: Vec<(f64, f64)>,
}

/// A line chart of one or more series.
#[derive(Debug, Clone)]
pub struct LineChart {
    /// Chart title.
    pub title: String,
    /// Horizontal axis label.
    pub x_label: String,
    /// Vertical axis label.
    pub y_label: String,
    /// Logarithmic horizontal axis.
    pub log_x: bool,
    /// Logarithmic vertical axis.
    pub log_y: bool,
    /// The curves.
    pub series: Vec<Series>,
}

/// Plot errors (I/O or drawing), with the file they concern.
pub type PlotResult<T> = Result<T, String>;

fn err(path: &Path, e: impl std::fmt::Display) -> String {
    format!("{}: {e}", path.display())
}

/// Renders into a temporary PNG beside `path`, then renames it into place.
fn atomic_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> PlotResult<()>,
) -> PlotResult<PathBuf> {
    register_font();
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if path.file_name().is_none() {
        return Err(err(path, "not a file name"));
    }
    // The atomic writes' temporary (unpredictable, created exclusively: a planted
    // symlink is never followed; removed on any error; the usual permissions);
    // plotters picks the encoder from the extension, so its name ends in .png.
    let tmp = crate::io::temp_beside(path, ".tmp.png").map_err(|e| err(dir, e))?;
    {
        let root = BitMapBackend::new(tmp.path(), size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(path, e))?;
        draw(&root)?;
        root.present().map_err(|e| err(path, e))?;
    }
    crate::io::persist(tmp, path).map_err(|e| err(path, e))?;
    Ok(path.to_path_buf())
}

/// Perceptually ordered colour map (viridis anchors, linear in between); `t` in [0, 1].
pub fn colour(t: f64) -> RGBColor {
    const ANCHORS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = t * (ANCHORS.len() - 1) as f64;
    let i = (x.floor() as usize).min(ANCHORS.len() - 2);
    let f = x - i as f64;
    let lerp = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (ANCHORS[i], ANCHORS[i + 1]);
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// Diverging colour map for signed values, `t` in [−1, 1]: −1 dark blue, 0 pure white,
/// +1 dark red, linear in RGB between anchors; clipped to [−1, 1], NaN drawn white.
///
/// The anchors are ColorBrewer's 11-class RdBu (Brewer 2002; colourblind-safe, blue for
/// negative), with its centre (247, 247, 247) made pure white so that a zero error reads
/// as "no colour".
pub fn diverging_colour(t: f64) -> RGBColor {
    const ANCHORS: [(u8, u8, u8); 11] = [
        (5, 48, 97),
        (33, 102, 172),
        (67, 147, 195),
        (146, 197, 222),
        (209, 229, 240),
        (255, 255, 255),
        (253, 219, 199),
        (244, 165, 130),
        (214, 96, 77),
        (178, 24, 43),
        (103, 0, 31),
    ];
    let t = if t.is_finite() { t.clamp(-1.0, 1.0) } else { 0.0 };
    let x = (t + 1.0) / 2.0 * (ANCHORS.len() - 1) as f64;
    let i = (x.floor() as usize).min(ANCHORS.len() - 2);
    let f = x - i as f64;
    let lerp = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (ANCHORS[i], ANCHORS[i + 1]);
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

const NO_DATA: RGBColor = RGBColor(190, 190, 190);

/// The smallest and largest finite value over `panels` (log10 of the positive values
/// for a panel with `log_colour`): a [`ColourScale::Fixed`] range that panels compared
/// side by side share. `None` when no value is finite.
pub fn shared_range(panels: &[Heatmap]) -> Option<(f64, f64)> {
    let (lo, hi) = panels
        .iter()
        .flat_map(|p| p.values.iter().map(move |&v| plotted(p.log_colour, v)))
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    lo.is_finite().then_some((lo, hi))
}

/// The coordinate a value is coloured by: itself, or log10 (NaN for v ≤ 0) on a log
/// colour scale.
fn plotted(log_colour: bool, v: f64) -> f64 {
    if !log_colour {
        v
    } else if v > 0.0 {
        v.log10()
    } else {
        f64::NAN
    }
}

/// Writes `panels` side by side, `columns` per row, each with its own colour bar.
pub fn heatmaps(path: &Path, panels: &[Heatmap], columns: usize) -> PlotResult<PathBuf> {
    let columns = columns.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(columns).max(1);
    for p in panels {
        if p.values.len() != p.nx * p.ny || p.nx == 0 || p.ny == 0 {
            return Err(err(
                path,
                format!("panel '{}': {} values for {}×{}", p.title, p.values.len(), p.nx, p.ny),
            ));
        }
    }
    atomic_png(path, (620 * columns as u32, 520 * rows as u32), |root| {
        let areas = root.split_evenly((rows, columns));
        for (p, area) in panels.iter().zip(areas.iter()) {
            heatmap_panel(path, area, p)?;
        }
        Ok(())
    })
}

fn heatmap_panel(
    path: &Path,
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    p: &Heatmap,
) -> PlotResult<()> {
    let e = |x| err(path, x);
    let w = area.dim_in_pixel().0;
    let (main, bar) = area.split_horizontally(w - 110);
    let transform = |v: f64| plotted(p.log_colour, v);
    let own = || {
        let (lo, mut hi) = shared_range(std::slice::from_ref(p)).unwrap_or((0.0, 1.0));
        if hi <= lo {
            hi = lo + 1.0;
        }
        (lo, hi)
    };
    let (lo, hi) = match p.scale {
        ColourScale::Own => own(),
        ColourScale::Fixed { lo, hi } if lo.is_finite() && hi.is_finite() && hi > lo => (lo, hi),
        ColourScale::Fixed { .. } => own(),
        ColourScale::Diverging { limit } => {
            let l = if limit.is_finite() && limit > 0.0 { limit } else { 1.0 };
            (-l, l)
        }
    };
    // The colour at a plotted value, and at a fraction `u` in [0, 1] of the bar.
    let at = |u: f64| match p.scale {
        ColourScale::Diverging { .. } => diverging_colour(2.0 * u - 1.0),
        _ => colour(u),
    };
    let t = |v: f64| (v - lo) / (hi - lo);
    let mut chart = ChartBuilder::on(&main)
        .caption(&p.title, (FAMILY, 20))
        .margin(8)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(p.x_range.0..p.x_range.1, p.y_range.0..p.y_range.1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(&p.x_label)
        .y_desc(&p.y_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 15))
        .draw()
        .map_err(e)?;
    let dx = (p.x_range.1 - p.x_range.0) / p.nx as f64;
    let dy = (p.y_range.1 - p.y_range.0) / p.ny as f64;
    chart
        .draw_series((0..p.ny).flat_map(|iy| {
            (0..p.nx).map(move |ix| {
                let v = transform(p.values[iy * p.nx + ix]);
                let c = if v.is_finite() {
                    at(t(v).clamp(0.0, 1.0))
                } else {
                    NO_DATA
                };
                let x0 = p.x_range.0 + ix as f64 * dx;
                let y0 = p.y_range.0 + iy as f64 * dy;
                Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], c.filled())
            })
        }))
        .map_err(e)?;
    // Colour bar: a one-column chart over the value range.
    let label = if p.log_colour {
        format!("log10 {}", p.colour_label)
    } else {
        p.colour_label.clone()
    };
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(38)
        .margin_bottom(53)
        .margin_right(8)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(e)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(label)
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .draw()
        .map_err(e)?;
    const STEPS: usize = 128;
    cb.draw_series((0..STEPS).map(|k| {
        let a = lo + (hi - lo) * k as f64 / STEPS as f64;
        let b = lo + (hi - lo) * (k + 1) as f64 / STEPS as f64;
        Rectangle::new([(0.0, a), (1.0, b)], at((k as f64 + 0.5) / STEPS as f64).filled())
    }))
    .map_err(e)?;
    Ok(())
}

/// Writes a line chart.
pub fn line_chart(path: &Path, chart: &LineChart) -> PlotResult<PathBuf> {
    let ok = |v: f64, log: bool| v.is_finite() && (!log || v > 0.0);
    let pts: Vec<Vec<(f64, f64)>> = chart
        .series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .copied()
                .filter(|&(x, y)| ok(x, chart.log_x) && ok(y, chart.log_y))
                .collect()
        })
        .collect();
    let all = pts.iter().flatten();
    let (x0, x1, y0, y1) = all.fold(
        (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY),
        |(a, b, c, d), &(x, y)| (a.min(x), b.max(x), c.min(y), d.max(y)),
    );
    if !x0.is_finite() || !y0.is_finite() {
        return Err(err(path, format!("chart '{}' has no drawable points", chart.title)));
    }
    let pad = |lo: f64, hi: f64, log: bool| {
        if log {
            let (l, h) = (lo.log10(), hi.log10());
            let m = ((h - l) * 0.05).max(0.05);
            (10f64.powf(l - m), 10f64.powf(h + m))
        } else {
            let m = ((hi - lo) * 0.05).max(1e-12 * hi.abs().max(1.0));
            (lo - m, hi + m)
        }
    };
    let xr = pad(x0, x1, chart.log_x);
    let yr = pad(y0, y1, chart.log_y);
    atomic_png(path, (900, 600), |root| match (chart.log_x, chart.log_y) {
        (false, false) => draw_lines(path, root, chart, &pts, xr.0..xr.1, yr.0..yr.1),
        (true, false) => draw_lines(path, root, chart, &pts, (xr.0..xr.1).log_scale(), yr.0..yr.1),
        (false, true) => draw_lines(path, root, chart, &pts, xr.0..xr.1, (yr.0..yr.1).log_scale()),
        (true, true) => draw_lines(
            path,
            root,
            chart,
            &pts,
            (xr.0..xr.1).log_scale(),
            (yr.0..yr.1).log_scale(),
        ),
    })
}

fn draw_lines<X, Y>(
    path: &Path,
    root: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    chart: &LineChart,
    pts: &[Vec<(f64, f64)>],
    x: X,
    y: Y,
) -> PlotResult<()>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let e = |x| err(path, x);
    let mut c = ChartBuilder::on(root)
        .caption(&chart.title, (FAMILY, 22))
        .margin(12)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(x, y)
        .map_err(e)?;
    c.configure_mesh()
        .x_labels(8)
        .y_labels(8)
        .x_label_formatter(&|v| short(*v))
        .y_label_formatter(&|v| short(*v))
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .draw()
        .map_err(e)?;
    for (k, (s, p)) in chart.series.iter().zip(pts).enumerate() {
        let col = Palette99::pick(k).to_rgba();
        // A marker at every point of a short series: measured points (a Pareto chart's
        // curves) read as such, and a series of one point (a method) shows at all.
        if p.len() <= 32 {
            c.draw_series(p.iter().map(|&xy| Circle::new(xy, 4, col.filled())))
                .map_err(e)?;
        }
        c.draw_series(LineSeries::new(p.iter().copied(), col.stroke_width(2)))
            .map_err(e)?
            .label(&s.name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FAMILY, 14))
        .draw()
        .map_err(e)?;
    Ok(())
}

/// Compact tick label: plain for moderate magnitudes, `1e-5` style otherwise.
fn short(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        let s = format!("{v:.1e}");
        s.replace(".0e", "e")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn is_png(p: &Path) -> bool {
        std::fs::read(p)
            .map(|b| b.starts_with(b"\x89PNG\r\n\x1a\n"))
            .unwrap_or(false)
    }

    #[test]
    fn heatmap_and_chart_write_pngs_atomically() {
        let dir = tempfile::tempdir().unwrap();
        let h = Heatmap {
            title: "x·y".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            x_range: (0.0, 1.0),
            y_range: (-1.0, 1.0),
            nx: 8,
            ny: 4,
            values: (0..32).map(|k| k as f64 - 3.0).collect(),
            colour_label: "v".into(),
            log_colour: true,
            scale: ColourScale::Own,
        };
        let p = heatmaps(&dir.path().join("h.png"), &[h.clone(), h], 2).unwrap();
        assert!(is_png(&p));
        let c = LineChart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_x: true,
            log_y: true,
            series: vec![Series {
                name: "x²".into(),
                points: (1..50).map(|k| (k as f64, (k * k) as f64)).collect(),
            }],
        };
        let q = line_chart(&dir.path().join("sub/c.png"), &c).unwrap();
        assert!(is_png(&q));
        // Only the two figures: no temporary files left behind.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
    }

    #[test]
    fn bad_inputs_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let c = LineChart {
            title: "empty".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_x: false,
            log_y: true,
            series: vec![Series {
                name: "neg".into(),
                points: vec![(1.0, -1.0), (2.0, f64::NAN)],
            }],
        };
        assert!(line_chart(&dir.path().join("c.png"), &c)
            .unwrap_err()
            .contains("no drawable points"));
        let h = Heatmap {
            title: "short".into(),
            x_label: String::new(),
            y_label: String::new(),
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.0),
            nx: 3,
            ny: 3,
            values: vec![0.0; 8],
            colour_label: String::new(),
            log_colour: false,
            scale: ColourScale::Own,
        };
        assert!(heatmaps(&dir.path().join("h.png"), &[h], 1)
            .unwrap_err()
            .contains("8 values for 3×3"));
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(short(1000.0), "1000");
        assert_eq!(short(0.25), "0.25");
        assert_eq!(short(1e-6), "1e-6");
        assert_eq!(short(2.5e7), "2.5e7");
        assert_eq!(short(0.0), "0");
    }

    /// The diverging map against its definition: 0 pure white, +1 the red end and −1
    /// the blue end of ColorBrewer's RdBu (its published hex #67001f and #053061),
    /// clipped beyond, and the anchors next to white.
    #[test]
    fn diverging_map_is_white_at_zero_and_clipped() {
        assert_eq!(diverging_colour(0.0), RGBColor(255, 255, 255));
        assert_eq!(diverging_colour(1.0), RGBColor(0x67, 0x00, 0x1f));
        assert_eq!(diverging_colour(-1.0), RGBColor(0x05, 0x30, 0x61));
        assert_eq!(diverging_colour(7.5), diverging_colour(1.0));
        assert_eq!(diverging_colour(-1e300), diverging_colour(-1.0));
        assert_eq!(diverging_colour(f64::NAN), RGBColor(255, 255, 255));
        // The anchors next to white, a tenth of the way out on either side: #fddbc7
        // (red side) at t = 0.2, #d1e5f0 (blue side) at t = −0.2.
        assert_eq!(diverging_colour(0.2), RGBColor(0xfd, 0xdb, 0xc7));
        assert_eq!(diverging_colour(-0.2), RGBColor(0xd1, 0xe5, 0xf0));
        // Positive is warm (red above blue), negative cool.
        let (r, b) = (diverging_colour(0.5), diverging_colour(-0.5));
        assert!(r.0 > r.2 && b.2 > b.0, "{r:?} {b:?}");
    }

    /// One range over several panels: the extremes of both, NaN cells ignored, log10
    /// of the positive values on a log panel; no finite value gives none.
    #[test]
    fn shared_range_spans_every_panel() {
        let panel = |values: Vec<f64>, log_colour: bool| Heatmap {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.0),
            nx: values.len(),
            ny: 1,
            values,
            colour_label: String::new(),
            log_colour,
            scale: ColourScale::Own,
        };
        let a = panel(vec![0.5, f64::NAN, 2.0], false);
        let b = panel(vec![-1.0, 1.5], false);
        assert_eq!(shared_range(&[a.clone(), b.clone()]), Some((-1.0, 2.0)));
        let c = panel(vec![0.01, 100.0, -3.0], true);
        assert_eq!(shared_range(&[c]), Some((-2.0, 2.0)));
        assert_eq!(shared_range(&[panel(vec![f64::NAN], false)]), None);
        // Fixed and diverging panels draw (including a degenerate limit).
        let dir = tempfile::tempdir().unwrap();
        let fixed = Heatmap {
            scale: ColourScale::Fixed { lo: -1.0, hi: 2.0 },
            ..a
        };
        let div = Heatmap {
            scale: ColourScale::Diverging { limit: 0.0 },
            ..b
        };
        assert!(is_png(&heatmaps(&dir.path().join("s.png"), &[fixed, div], 2).unwrap()));
    }

    #[test]
    fn colour_map_ends() {
        assert_eq!(colour(0.0), RGBColor(68, 1, 84));
        assert_eq!(colour(1.0), RGBColor(253, 231, 37));
        assert_eq!(colour(f64::NAN), colour(0.0));
    }
}
