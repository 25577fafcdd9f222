//! Pictures of a state: three orthographic views of the box (front: x right, y up; side:
//! z right, y up; top: x right, z down; a planar domain's front alone), particles drawn back to front and coloured by speed
//! or density on the viridis scale with its colour bar, the box's walls drawn. One PNG, or
//! the frames of a run as an animated GIF. Drawn with plotters and the embedded DejaVu Sans.

use crate::io::export::Snapshot;
use crate::lab::chart::{in_plain_words, register_font};
use crate::sim::params::Domain;
use glam::DVec3;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;
use std::error::Error;
use std::path::Path;

/// Pixel size of a rendered frame.
pub const SIZE: (u32, u32) = (1280, 560);

/// Space around the box in each view, as a fraction of its largest edge (particles just
/// outside stay visible): 1 cm around the course's box.
const MARGIN: f64 = 0.01 / 0.18;

/// Pixels the three views may take across, gaps and the colour bar beside them excluded.
const VIEWS_WIDTH: f64 = 1015.0;

/// What the colours show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Colouring {
    /// |v| in m/s, from 0.
    Speed,
    /// Density in kg/m^3.
    Density,
}

impl Colouring {
    /// The colour bar's label.
    pub fn label(self) -> &'static str {
        match self {
            Colouring::Speed => "speed (m/s)",
            Colouring::Density => "density (kg/m^3)",
        }
    }

    /// The value each particle of `snapshot` is coloured by.
    pub fn values(self, snapshot: &Snapshot) -> Vec<f64> {
        match self {
            Colouring::Speed => snapshot.velocity.iter().map(|v| v.length()).collect(),
            Colouring::Density => snapshot.density.clone(),
        }
    }

    /// The colour range that covers `values`: from 0 for speed, min to max for density.
    pub fn auto_range(self, values: &[f64]) -> (f64, f64) {
        let finite = values.iter().copied().filter(|v| v.is_finite());
        let (low, high) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        let low = if self == Colouring::Speed { 0.0 } else { low };
        match (low >= high, self) {
            // Nothing moves: speeds from 0, as the bar says.
            (true, Colouring::Speed) => (0.0, 1.0),
            (true, _) => {
                let centre = if low.is_finite() { low } else { 0.0 };
                (centre - 0.5, centre + 0.5)
            }
            (false, _) => (low, high),
        }
    }
}

/// One of the three views: which axes run right and up (or down), and along which axis
/// the eye looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// The view's caption.
    pub name: &'static str,
    /// The axis drawn left to right.
    pub right: usize,
    /// The axis drawn bottom to top (or top to bottom when `down`).
    pub up: usize,
    /// Whether `up` grows downwards on the page (the top view's z).
    pub down: bool,
    /// The axis the eye looks along: particles with larger values are drawn last.
    pub depth: usize,
}

/// The front, side and top views.
pub const VIEWS: [View; 3] = [
    View {
        name: "front (x, y)",
        right: 0,
        up: 1,
        down: false,
        depth: 2,
    },
    View {
        name: "side (z, y)",
        right: 2,
        up: 1,
        down: false,
        depth: 0,
    },
    View {
        name: "top (x, z)",
        right: 0,
        up: 2,
        down: true,
        depth: 1,
    },
];

/// Where each view sits in the frame: a common scale and each view's box origin.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Pixels per metre, the same in every view.
    pub scale: f64,
    /// For each of [`VIEWS`], the pixel of the box's low corner (left and bottom, or left
    /// and top for a view that grows downwards).
    pub origins: [(i32, i32); 3],
    /// The box drawn.
    pub low: DVec3,
    /// Its high corner.
    pub high: DVec3,
    /// The space around it (m).
    pub margin: f64,
    /// How many of [`VIEWS`] are drawn: all three, or the front alone for a planar
    /// domain (whose side and top views would be slivers one spacing deep).
    pub views: usize,
    /// The left edge of the colour bar, right of the last view.
    pub bar_x: i32,
    /// The frame's pixel size: [`SIZE`], or narrower where the views and the colour bar
    /// leave the rest of it empty (a planar domain's one view), down to [`MIN_WIDTH`].
    pub size: (u32, u32),
}

/// The narrowest frame: room for the title and the subtitle.
pub const MIN_WIDTH: u32 = 560;

/// Pixels from the colour bar's left edge to the frame's right edge: the bar, its labels
/// and a margin.
const BAR_AND_LABELS: i32 = 150;

impl Layout {
    /// The views of `domain`'s box, as large as the frame's height and width allow.
    pub fn of(domain: &Domain) -> Self {
        let extent = domain.extent();
        let margin = MARGIN * extent.max_element();
        let (top, bottom) = (70.0, 40.0);
        let views = if domain.planar { 1 } else { VIEWS.len() };
        let across: f64 = VIEWS[..views]
            .iter()
            .map(|view| extent[view.right] + 2.0 * margin)
            .sum();
        let scale =
            ((SIZE.1 as f64 - top - bottom) / (extent.y + 2.0 * margin)).min(VIEWS_WIDTH / across);
        let panel = |axis: usize| (extent[axis] + 2.0 * margin) * scale;
        let gap = 30.0;
        let baseline = top + (extent.y + margin) * scale;
        let mut left = 30.0;
        let mut origins = [(0, 0); 3];
        for (origin, view) in origins.iter_mut().zip(&VIEWS[..views]) {
            let x = left + margin * scale;
            let y = if view.down {
                top + margin * scale
            } else {
                baseline
            };
            *origin = (x.round() as i32, y.round() as i32);
            left += panel(view.right) + gap;
        }
        let last = views - 1;
        let last_width = (extent[VIEWS[last].right] + margin) * scale;
        let bar_x = origins[last].0 + last_width as i32 + 40;
        let width = (bar_x + BAR_AND_LABELS).clamp(MIN_WIDTH as i32, SIZE.0 as i32);
        Layout {
            scale,
            origins,
            low: domain.min,
            high: domain.max,
            margin,
            views,
            bar_x,
            size: (width as u32, SIZE.1),
        }
    }

    /// The pixel where view `index` draws the point `p`.
    pub fn pixel(&self, index: usize, p: DVec3) -> (i32, i32) {
        let view = VIEWS[index];
        let (x0, y0) = self.origins[index];
        let right = (p[view.right] - self.low[view.right]) * self.scale;
        let up = (p[view.up] - self.low[view.up]) * self.scale;
        let y = if view.down {
            y0 as f64 + up
        } else {
            y0 as f64 - up
        };
        ((x0 as f64 + right).round() as i32, y.round() as i32)
    }

    /// Whether view `index` shows `p` (inside the box plus the margin).
    fn shows(&self, index: usize, p: DVec3) -> bool {
        let view = VIEWS[index];
        [view.right, view.up].iter().all(|&axis| {
            p[axis] >= self.low[axis] - self.margin && p[axis] <= self.high[axis] + self.margin
        })
    }
}

/// How to draw frames.
#[derive(Debug, Clone)]
pub struct Style {
    /// The first title line, e.g. the input's name.
    pub title: String,
    /// Particles per metre (sets the particles' drawn size).
    pub ppm: f64,
    /// What the colours show.
    pub colouring: Colouring,
    /// The colour range, or `None` for [`Colouring::auto_range`].
    pub range: Option<(f64, f64)>,
}

/// Writes `snapshot` as a PNG at `path` (an error in the system's words, naming no file).
pub fn render_png(snapshot: &Snapshot, style: &Style, path: &Path) -> Result<(), Box<dyn Error>> {
    register_font()?;
    let size = Layout::of(&snapshot.domain).size;
    let root = BitMapBackend::new(path, size).into_drawing_area();
    let drawn = draw(&root, snapshot, style).and_then(|()| Ok(root.present()?));
    drawn.map_err(in_plain_words)
}

/// An animated GIF being written, one frame at a time.
pub struct Animation<'a> {
    root: DrawingArea<BitMapBackend<'a>, Shift>,
}

impl<'a> Animation<'a> {
    /// Starts a GIF at `path` of frames of `domain`, showing each for `delay_ms`
    /// milliseconds.
    pub fn create(path: &'a Path, domain: &Domain, delay_ms: u32) -> Result<Self, Box<dyn Error>> {
        register_font()?;
        let size = Layout::of(domain).size;
        let backend = BitMapBackend::gif(path, size, delay_ms);
        let root = backend.map_err(in_plain_words)?;
        Ok(Animation {
            root: root.into_drawing_area(),
        })
    }

    /// Appends a frame of `snapshot`.
    pub fn push(&mut self, snapshot: &Snapshot, style: &Style) -> Result<(), Box<dyn Error>> {
        let drawn = draw(&self.root, snapshot, style).and_then(|()| Ok(self.root.present()?));
        drawn.map_err(in_plain_words)
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    snapshot: &Snapshot,
    style: &Style,
) -> Result<(), Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    let layout = Layout::of(&snapshot.domain);
    let values = style.colouring.values(snapshot);
    let (low, high) = style
        .range
        .unwrap_or_else(|| style.colouring.auto_range(&values));
    root.fill(&WHITE)?;
    let outside = snapshot
        .position
        .iter()
        .filter(|&&p| !snapshot.domain.contains(p))
        .count();
    let subtitle = format!(
        "step {} (t = {:.3} s), {} particles, {outside} outside the box",
        snapshot.step,
        snapshot.time,
        snapshot.len()
    );
    root.draw(&Text::new(
        style.title.as_str(),
        (30, 12),
        ("sans-serif", 22),
    ))?;
    root.draw(&Text::new(subtitle, (30, 40), ("sans-serif", 15)))?;
    let radius = ((0.45 / style.ppm) * layout.scale).round().max(1.0) as i32;
    let extent = layout.high - layout.low;
    for (index, view) in VIEWS[..layout.views].iter().enumerate() {
        let (x0, y0) = layout.origins[index];
        let width = (extent[view.right] * layout.scale).round() as i32;
        let height = (extent[view.up] * layout.scale).round() as i32;
        let (top, bottom) = if view.down {
            (y0, y0 + height)
        } else {
            (y0 - height, y0)
        };
        root.draw(&Rectangle::new(
            [(x0, top), (x0 + width, bottom)],
            BLACK.mix(0.6).stroke_width(1),
        ))?;
        let caption_y = bottom + (layout.margin * layout.scale) as i32 + 4;
        root.draw(&Text::new(view.name, (x0, caption_y), ("sans-serif", 14)))?;
        let mut order: Vec<usize> = (0..snapshot.len())
            .filter(|&i| layout.shows(index, snapshot.position[i]))
            .collect();
        order.sort_by(|&a, &b| {
            let depth = |i: usize| snapshot.position[i][view.depth];
            depth(a).total_cmp(&depth(b))
        });
        for i in order {
            let colour = colour_of(values[i], low, high);
            let centre = layout.pixel(index, snapshot.position[i]);
            root.draw(&Circle::new(centre, radius, colour.filled()))?;
        }
    }
    draw_colour_bar(root, &layout, style.colouring.label(), low, high)?;
    Ok(())
}

fn colour_of(value: f64, low: f64, high: f64) -> RGBColor {
    if !value.is_finite() {
        return RGBColor(255, 0, 255);
    }
    ViridisRGB::get_color_normalized(value.clamp(low, high), low, high)
}

/// A vertical colour bar right of the views, labelled at both ends and the middle.
fn draw_colour_bar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    layout: &Layout,
    label: &str,
    low: f64,
    high: f64,
) -> Result<(), Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    let extent = layout.high - layout.low;
    let x = layout.bar_x;
    // As tall as the front view, and at least 200 pixels (for a flat box's thin views),
    // below the title.
    let height = ((extent.y * layout.scale) as i32).max(200);
    let bottom = layout.origins[0].1.max(70 + height);
    let top = bottom - height;
    for y in top..=bottom {
        let fraction = (bottom - y) as f64 / (bottom - top) as f64;
        let colour = colour_of(low + fraction * (high - low), low, high);
        root.draw(&PathElement::new([(x, y), (x + 18, y)], colour))?;
    }
    root.draw(&Rectangle::new(
        [(x, top), (x + 18, bottom)],
        BLACK.mix(0.6),
    ))?;
    for fraction in [0.0, 0.5, 1.0] {
        let y = bottom - (fraction * (bottom - top) as f64) as i32;
        let value = low + fraction * (high - low);
        root.draw(&Text::new(
            format!("{value:.4}"),
            (x + 24, y - 7),
            ("sans-serif", 13),
        ))?;
    }
    root.draw(&Text::new(label, (x - 10, top - 24), ("sans-serif", 14)))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::params::{BOX_MAX, BOX_MIN};
    use crate::sim::simulation::Simulation;

    #[test]
    fn a_planar_domain_is_drawn_in_its_front_view_alone_and_larger() {
        let long_tank = Domain {
            min: DVec3::ZERO,
            max: DVec3::new(1.0, 0.5, 0.3),
            ..Domain::COURSE
        };
        let (solid, planar) = (
            Layout::of(&long_tank),
            Layout::of(&long_tank.section(100.0)),
        );
        assert_eq!((solid.views, planar.views), (3, 1));
        assert!(
            planar.scale > 1.5 * solid.scale,
            "{} {}",
            planar.scale,
            solid.scale
        );
        let (x, y) = planar.pixel(0, DVec3::new(1.0, 0.5, 0.0));
        assert!((0..SIZE.0 as i32).contains(&x) && (0..SIZE.1 as i32).contains(&y));
        // Its colour bar beside its one view, not where a solid box's top view ends.
        assert!(planar.bar_x > x && planar.bar_x + 120 < planar.size.0 as i32);
        assert!(planar.bar_x < solid.bar_x, "{planar:?} {solid:?}");
        // A tall section leaves no empty half: its frame narrows to its view and bar.
        let column = Domain {
            max: DVec3::new(0.1, 0.5, 0.3),
            ..long_tank
        };
        let narrow = Layout::of(&column.section(100.0));
        assert_eq!(narrow.size, (MIN_WIDTH, SIZE.1), "{narrow:?}");
        assert_eq!(Layout::of(&Domain::COURSE).size, SIZE);
    }

    #[test]
    fn the_layout_keeps_every_box_corner_in_the_frame_and_the_views_apart() {
        let long_tank = Domain {
            min: DVec3::ZERO,
            max: DVec3::new(1.0, 0.5, 0.3),
            ..Domain::COURSE
        };
        let tower = Domain {
            min: DVec3::splat(-1.0),
            max: DVec3::new(-0.9, 2.0, -0.8),
            ..Domain::COURSE
        };
        for domain in [Domain::COURSE, long_tank, tower] {
            let layout = Layout::of(&domain);
            let (low, high) = (domain.min, domain.max);
            let mut spans = Vec::new();
            for index in 0..3 {
                let corners = [low, high, DVec3::new(low.x, high.y, high.z)];
                let pixels: Vec<(i32, i32)> =
                    corners.iter().map(|&c| layout.pixel(index, c)).collect();
                for (x, y) in &pixels {
                    let inside = (0..SIZE.0 as i32).contains(x) && (0..SIZE.1 as i32).contains(y);
                    assert!(inside, "{domain:?} view {index}: {pixels:?}");
                }
                let xs = pixels.iter().map(|p| p.0);
                spans.push((xs.clone().min().unwrap(), xs.max().unwrap()));
            }
            assert!(
                spans[0].1 < spans[1].0 && spans[1].1 < spans[2].0,
                "{spans:?}"
            );
            // The colour bar stays in the frame, right of the views.
            assert!(layout.bar_x > spans[2].1, "{domain:?}: {}", layout.bar_x);
            assert!(
                layout.bar_x + 120 < layout.size.0 as i32,
                "{domain:?}: {layout:?}"
            );
            // Up is up in the front view and down in the top view.
            assert!(layout.pixel(0, high).1 < layout.pixel(0, low).1);
            assert!(layout.pixel(2, high).1 > layout.pixel(2, low).1);
        }
        // The course's box fills the frame's height, as before boxes had sizes.
        let course = Layout::of(&Domain::COURSE);
        assert!(
            (course.scale - 450.0 / 0.2).abs() < 1e-9,
            "{}",
            course.scale
        );
    }

    #[test]
    fn ranges_cover_the_values() {
        assert_eq!(Colouring::Speed.auto_range(&[0.5, 2.0, 1.0]), (0.0, 2.0));
        assert_eq!(
            Colouring::Density.auto_range(&[900.0, 1100.0]),
            (900.0, 1100.0)
        );
        assert_eq!(Colouring::Density.auto_range(&[1000.0; 3]), (999.5, 1000.5));
        // At rest, speeds still start at 0 (the sixth hostile pass: -0.5 to 0.5 m/s).
        assert_eq!(Colouring::Speed.auto_range(&[f64::NAN, 0.0]), (0.0, 1.0));
        assert_eq!(Colouring::Speed.auto_range(&[0.0; 3]), (0.0, 1.0));
    }

    /// A 10 x 10 x 10 block at rest in the low corner, at 200 particles per metre.
    fn corner_snapshot() -> Snapshot {
        let particles = crate::lab::scene::corner_block(200.0, 1000).unwrap();
        Snapshot::of(&Simulation::new(200.0, particles).unwrap(), 0)
    }

    /// The RGB pixel at (x, y) of a decoded PNG.
    fn pixel(path: &Path, (x, y): (i32, i32)) -> [u8; 3] {
        let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut buffer = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buffer).unwrap();
        assert_eq!((info.width, info.height), SIZE);
        let at = (y as usize * info.width as usize + x as usize) * 3;
        [buffer[at], buffer[at + 1], buffer[at + 2]]
    }

    #[test]
    fn particles_colour_the_pixels_where_they_are_and_nowhere_else() {
        let snapshot = corner_snapshot();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("corner.png");
        let style = Style {
            title: "corner".into(),
            ppm: 200.0,
            colouring: Colouring::Density,
            range: None,
        };
        render_png(&snapshot, &style, &path).unwrap();
        let layout = Layout::of(&Domain::COURSE);
        let white = [255, 255, 255];
        // A 10 x 10 x 10 block of spacing 5 mm fills 5 cm from the low corner; particle
        // 555 is in its middle.
        let inside = snapshot.position[555];
        assert!((inside - (BOX_MIN + 0.0275)).length() < 1e-12, "{inside}");
        let empty = BOX_MAX - 0.03;
        for view in 0..3 {
            assert_ne!(
                pixel(&path, layout.pixel(view, inside)),
                white,
                "view {view}"
            );
            assert_eq!(
                pixel(&path, layout.pixel(view, empty)),
                white,
                "view {view}"
            );
        }
    }

    #[test]
    fn an_animation_holds_one_frame_per_push() {
        let snapshot = corner_snapshot();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("corner.gif");
        {
            let mut animation = Animation::create(&path, &snapshot.domain, 50).unwrap();
            let style = Style {
                title: "corner".into(),
                ppm: 200.0,
                colouring: Colouring::Speed,
                range: Some((0.0, 1.0)),
            };
            for step in 0..3 {
                let snapshot = Snapshot {
                    step,
                    ..snapshot.clone()
                };
                animation.push(&snapshot, &style).unwrap();
            }
        }
        let mut options = gif::DecodeOptions::new();
        options.set_color_output(gif::ColorOutput::RGBA);
        let mut decoder = options
            .read_info(std::fs::File::open(&path).unwrap())
            .unwrap();
        assert_eq!((decoder.width() as u32, decoder.height() as u32), SIZE);
        let mut frames = 0;
        while decoder.read_next_frame().unwrap().is_some() {
            frames += 1;
        }
        assert_eq!(frames, 3);
    }
}
