//! Pictures of the map in the paper's colours (Fig. 4 d–f of `mim-lidar-intensity-navigation.txt`):
//! solid cells in white to grey by intensity (brighter is more intense), free space black,
//! passable cells green, glass yellow, cells never observed dark slate; the robot pink with a
//! heading tick, the goal blue. [`render_map_with_legend`] adds a panel that names every colour,
//! a scale bar and the grid's cell size. Pure: returns RGB pixels; the caller encodes them.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

/// An RGB image, row-major, 3 bytes a pixel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height * 3` bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// A black image.
    pub fn new(width: usize, height: usize) -> Self {
        Image {
            width,
            height,
            rgb: vec![0; width * height * 3],
        }
    }

    /// Writes the image to `path` as an 8-bit RGB PNG.
    pub fn write_png(&self, path: &std::path::Path) -> Result<(), png::EncodingError> {
        let file = std::io::BufWriter::new(std::fs::File::create(path)?);
        let mut enc = png::Encoder::new(file, self.width as u32, self.height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header()?.write_image_data(&self.rgb)
    }

    /// Colours pixel (x, y); nothing outside the image.
    pub fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
            let o = (y as usize * self.width + x as usize) * 3;
            self.rgb[o..o + 3].copy_from_slice(&c);
        }
    }

    /// A line from (x0, y0) to (x1, y1), pixels.
    pub fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [u8; 3]) {
        let steps = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as i64;
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            self.put(
                (x0 + (x1 - x0) * t).round() as i64,
                (y0 + (y1 - y0) * t).round() as i64,
                c,
            );
        }
    }

    /// `text` from (x, y) (its top left corner), 8 × 8 pixels a character in the public-domain
    /// font8x8 font; characters outside ASCII are drawn as `?`.
    pub fn text(&mut self, x: i64, y: i64, text: &str, c: [u8; 3]) {
        for (k, ch) in text.chars().enumerate() {
            let code = if ch.is_ascii() {
                ch as usize
            } else {
                '?' as usize
            };
            let glyph = font8x8::legacy::BASIC_LEGACY[code];
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        self.put(x + 8 * k as i64 + col, y + row as i64, c);
                    }
                }
            }
        }
    }

    /// A filled rectangle, pixels.
    pub fn rect(&mut self, x: i64, y: i64, w: i64, h: i64, c: [u8; 3]) {
        for yy in y..y + h {
            for xx in x..x + w {
                self.put(xx, yy, c);
            }
        }
    }

    /// A filled disc of radius `r` around (cx, cy), pixels.
    pub fn disc(&mut self, cx: f64, cy: f64, r: f64, c: [u8; 3]) {
        let ri = r.ceil() as i64;
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                if ((dx * dx + dy * dy) as f64) <= r * r {
                    self.put(cx as i64 + dx, cy as i64 + dy, c);
                }
            }
        }
    }
}

/// Colours.
pub const FREE: [u8; 3] = [0, 0, 0];
/// Passable (grass, curtains).
pub const PASSABLE: [u8; 3] = [40, 190, 60];
/// Glass.
pub const GLASS: [u8; 3] = [250, 220, 0];
/// Suspected glass: a pane's line drawn on where the pane was not seen (dark yellow).
pub const SUSPECTED_GLASS: [u8; 3] = [150, 120, 0];
/// Never observed.
pub const UNKNOWN: [u8; 3] = [38, 44, 56];
/// The robot.
pub const ROBOT: [u8; 3] = [255, 105, 180];
/// The goal.
pub const GOAL: [u8; 3] = [40, 110, 255];
/// The driven path.
pub const PATH: [u8; 3] = [0, 200, 255];
/// The legend panel's background and text.
const PANEL: [u8; 3] = [22, 22, 26];
const INK: [u8; 3] = [235, 235, 235];

/// What to draw on top of the cells.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Marks {
    /// Robot footprint radius, m (drawn at the centre, heading up).
    pub robot_radius_m: f64,
    /// The robot's body, length (along x) × width, m: drawn as its outline around the centre,
    /// turned with it, where the profile gives one (a long body such as Spot's).
    pub body_m: Option<(f64, f64)>,
    /// The goal in the robot frame (x forward, y left), m.
    pub goal: Option<(f64, f64)>,
    /// The driven path in the robot frame, m, oldest first.
    pub path: Vec<(f64, f64)>,
}

/// Pixels per cell.
pub const SCALE: usize = 3;

/// Image pixel of robot-frame (x, y) in [`render_map`]'s picture: x forward is up, y left is
/// left.
pub fn pixel(grid: GridSpec, x: f64, y: f64) -> (f64, f64) {
    let h = f64::from(grid.half_extent_m());
    let px_per_m = SCALE as f64 / f64::from(grid.cell_m);
    ((h - y) * px_per_m, (h - x) * px_per_m)
}

/// The map: `classes` per cell, `intensity` per cell (the brightest of the main layers' I_j,
/// normalised: 1 is one full-scale return per cell).
pub fn render_map(grid: GridSpec, classes: &[u8], intensity: &[f32], marks: &Marks) -> Image {
    let n = grid.cells;
    let mut img = Image::new(n * SCALE, n * SCALE);
    let per_return = 1.0 / (grid.cell_m * grid.cell_m);
    for r in 0..n {
        for c in 0..n {
            let i = grid.index(r, c);
            let colour = match classes.get(i).copied().unwrap_or(cell_class::UNKNOWN) {
                cell_class::FREE => FREE,
                cell_class::PASSABLE => PASSABLE,
                cell_class::GLASS => GLASS,
                cell_class::SUSPECTED_GLASS => SUSPECTED_GLASS,
                cell_class::SOLID => {
                    let v = intensity.get(i).copied().unwrap_or(0.0) / (2.0 * per_return);
                    let g = (110.0 + 145.0 * v.clamp(0.0, 1.0)) as u8;
                    [g, g, g]
                }
                _ => UNKNOWN,
            };
            let (px, py) = ((n - 1 - c) * SCALE, (n - 1 - r) * SCALE);
            for dy in 0..SCALE {
                for dx in 0..SCALE {
                    img.put((px + dx) as i64, (py + dy) as i64, colour);
                }
            }
        }
    }
    let px_per_m = SCALE as f64 / f64::from(grid.cell_m);
    for w in marks.path.windows(2) {
        img.line(
            pixel(grid, w[0].0, w[0].1),
            pixel(grid, w[1].0, w[1].1),
            PATH,
        );
    }
    let (cx, cy) = pixel(grid, 0.0, 0.0);
    match marks.body_m {
        Some((l, w)) if l > 0.0 && w > 0.0 => {
            // the outline, two pixels thick, and a small disc at the centre
            let corners = [(l, w), (l, -w), (-l, -w), (-l, w)].map(|(x, y)| (x / 2.0, y / 2.0));
            for k in 0..4 {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                for d in [0.0, 1.0] {
                    let (pa, pb) = (pixel(grid, a.0, a.1), pixel(grid, b.0, b.1));
                    img.line((pa.0 + d, pa.1), (pb.0 + d, pb.1), ROBOT);
                    img.line((pa.0, pa.1 + d), (pb.0, pb.1 + d), ROBOT);
                }
            }
            img.disc(cx, cy, 2.0, ROBOT);
        }
        _ => img.disc(cx, cy, (marks.robot_radius_m * px_per_m).max(3.0), ROBOT),
    }
    for k in 0..(marks.robot_radius_m * px_per_m * 1.6) as i64 {
        img.put(cx as i64, cy as i64 - k, ROBOT);
    }
    if let Some((gx, gy)) = marks.goal {
        let (px, py) = pixel(grid, gx, gy);
        img.disc(px, py, 5.0, GOAL);
    }
    img
}

/// `text` in lines of at most `width` characters, broken between words where it can be.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for word in text.split_whitespace() {
        let mut word = word.to_string();
        while word.chars().count() > width {
            if !cur.is_empty() {
                lines.push(std::mem::take(&mut cur));
            }
            let rest = word.split_off(
                word.char_indices()
                    .nth(width)
                    .map_or(word.len(), |(i, _)| i),
            );
            lines.push(std::mem::replace(&mut word, rest));
        }
        if !cur.is_empty() && cur.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(&word);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// Width of the legend panel, pixels.
pub const LEGEND_WIDTH: usize = 200;

/// The longest of 0.5, 1, 2, 5, 10, 20 and 50 m whose bar fits in `max_px` pixels at
/// `px_per_m` (at least the shortest).
pub fn scale_bar_m(px_per_m: f64, max_px: f64) -> f64 {
    [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0]
        .into_iter()
        .take_while(|&m| m * px_per_m <= max_px)
        .last()
        .unwrap_or(0.5)
}

/// [`render_map`] with a panel on its right: what each colour means (those of the marks drawn
/// only), a scale bar, and the grid's size. `title` heads the panel (e.g. the map's sequence
/// number).
pub fn render_map_with_legend(
    grid: GridSpec,
    classes: &[u8],
    intensity: &[f32],
    marks: &Marks,
    title: &str,
) -> Image {
    let map = render_map(grid, classes, intensity, marks);
    let mut entries: Vec<([u8; 3], &str)> = vec![
        (FREE, "free"),
        ([230, 230, 230], "solid, bright:"),
        ([120, 120, 120], "solid, dim:"),
        (PASSABLE, "passable"),
        (GLASS, "glass"),
        (SUSPECTED_GLASS, "suspected glass"),
        (UNKNOWN, "never seen"),
        (ROBOT, "robot (up: ahead)"),
    ];
    if marks.goal.is_some() {
        entries.push((GOAL, "goal"));
    }
    if marks.path.len() > 1 {
        entries.push((PATH, "driven path"));
    }
    let line = 16;
    let title = wrap(title, (LEGEND_WIDTH - 16) / 8);
    let panel_h = 12 + (title.len() + 1) * line + entries.len() * line + 4 * line;
    let (w, h) = (map.width + LEGEND_WIDTH, map.height.max(panel_h));
    let mut img = Image::new(w, h);
    img.rect(0, 0, w as i64, h as i64, PANEL);
    for y in 0..map.height {
        let row = y * map.width * 3;
        let to = y * w * 3;
        img.rgb[to..to + map.width * 3].copy_from_slice(&map.rgb[row..row + map.width * 3]);
    }
    let x0 = map.width as i64 + 10;
    let mut y = 10;
    for t in &title {
        img.text(x0, y, t, INK);
        y += line as i64;
    }
    y += line as i64;
    for (colour, label) in &entries {
        img.rect(x0, y - 2, 12, 12, [90, 90, 90]);
        img.rect(x0 + 1, y - 1, 10, 10, *colour);
        let label = match *label {
            "solid, bright:" => "solid: intense",
            "solid, dim:" => "solid: faint",
            l => l,
        };
        img.text(x0 + 18, y, label, INK);
        y += line as i64;
    }
    // the scale bar, with end ticks
    let px_per_m = SCALE as f64 / f64::from(grid.cell_m);
    let bar_m = scale_bar_m(px_per_m, (LEGEND_WIDTH - 30) as f64);
    let bar_px = (bar_m * px_per_m).round() as i64;
    y += line as i64 / 2;
    img.rect(x0, y + 4, bar_px, 3, INK);
    img.rect(x0, y, 2, 11, INK);
    img.rect(x0 + bar_px - 2, y, 2, 11, INK);
    y += line as i64;
    let label = if bar_m < 1.0 {
        format!("{:.0} cm", bar_m * 100.0)
    } else {
        format!("{bar_m:.0} m")
    };
    img.text(x0, y, &label, INK);
    y += line as i64;
    let side = grid.cells as f64 * f64::from(grid.cell_m);
    img.text(x0, y, &format!("{side:.0} m, cell {} m", grid.cell_m), INK);
    img
}

/// Every layer side by side, in order, each in grey (white where I_j is highest).
pub fn render_layers(grid: GridSpec, layers: &[f32], count: usize) -> Image {
    let n = grid.cells;
    let gap = 4;
    let w = count * n * SCALE + count.saturating_sub(1) * gap;
    let mut img = Image::new(w.max(1), n * SCALE);
    let per_return = 1.0 / (grid.cell_m * grid.cell_m);
    for j in 0..count {
        let x0 = j * (n * SCALE + gap);
        for r in 0..n {
            for c in 0..n {
                let v = layers
                    .get(j * n * n + grid.index(r, c))
                    .copied()
                    .unwrap_or(0.0)
                    / (2.0 * per_return);
                let g = if v > 0.0 {
                    (60.0 + 195.0 * v.clamp(0.0, 1.0)) as u8
                } else {
                    0
                };
                for dy in 0..SCALE {
                    for dx in 0..SCALE {
                        img.put(
                            (x0 + (n - 1 - c) * SCALE + dx) as i64,
                            ((n - 1 - r) * SCALE + dy) as i64,
                            [g, g, g],
                        );
                    }
                }
            }
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_get_the_paper_colours_in_the_robot_frame() {
        let grid = GridSpec {
            cells: 10,
            cell_m: 1.0,
        };
        let mut classes = vec![cell_class::FREE; 100];
        // 3 m ahead (x), 2 m left (y): glass
        let (r, c) = grid.cell_of(3.5, 2.5).expect("inside");
        classes[grid.index(r, c)] = cell_class::GLASS;
        let img = render_map(grid, &classes, &[0.0; 100], &Marks::default());
        assert_eq!((img.width, img.height), (30, 30));
        // ahead is up, left is left: the pixel of (3.5, 2.5) is at column (5 - 2.5) * 3, row (5 - 3.5) * 3
        let (px, py) = (7, 4);
        let o = (py * img.width + px) * 3;
        assert_eq!(&img.rgb[o..o + 3], &GLASS);
        // the robot is drawn at the centre
        let o = (15 * img.width + 15) * 3;
        assert_eq!(&img.rgb[o..o + 3], &ROBOT);
    }

    fn colour_at(img: &Image, x: impl Into<f64>, y: impl Into<f64>) -> [u8; 3] {
        let (x, y) = (x.into().round() as usize, y.into().round() as usize);
        let o = (y * img.width + x) * 3;
        [img.rgb[o], img.rgb[o + 1], img.rgb[o + 2]]
    }

    #[test]
    fn the_legend_sits_beside_the_map_and_its_scale_bar_is_true_to_the_grid() {
        let grid = GridSpec {
            cells: 200,
            cell_m: 0.1,
        };
        let classes = vec![cell_class::FREE; 200 * 200];
        let marks = Marks {
            robot_radius_m: 0.3,
            goal: Some((5.0, 0.0)),
            ..Marks::default()
        };
        let plain = render_map(grid, &classes, &[], &marks);
        let img = render_map_with_legend(grid, &classes, &[], &marks, "map 7");
        assert_eq!((img.width, img.height), (600 + LEGEND_WIDTH, 600));
        // the map is unchanged on the left
        for y in [0, 299, 599] {
            let (a, b) = (y * img.width * 3, y * plain.width * 3);
            assert_eq!(img.rgb[a..a + 1800], plain.rgb[b..b + 1800]);
        }
        // 30 px a metre, a bar of at most 170 px: 5 m
        assert_eq!(scale_bar_m(30.0, 170.0), 5.0);
        assert_eq!(scale_bar_m(3.0, 170.0), 50.0);
        assert_eq!(scale_bar_m(300.0, 170.0), 0.5);
        // the bar's 150 px are drawn in ink on one row of the panel
        let ink_run = (0..img.height)
            .map(|y| {
                (600..img.width)
                    .filter(|&x| colour_at(&img, x as f64, y as f64) == INK)
                    .count()
            })
            .max()
            .unwrap_or(0);
        assert_eq!(ink_run, 150, "the scale bar");
        // a swatch of each colour named, the goal's among them; no path, none for it
        let has = |c: [u8; 3]| {
            (0..img.height).any(|y| (610..630).any(|x| colour_at(&img, x as f64, y as f64) == c))
        };
        for c in [GLASS, SUSPECTED_GLASS, PASSABLE, UNKNOWN, ROBOT, GOAL] {
            assert!(has(c), "{c:?}");
        }
        assert!(!has(PATH));
    }

    #[test]
    fn a_title_wraps_between_words() {
        assert_eq!(
            wrap("scenario 1: indoor glass wall: map 194", 23),
            ["scenario 1: indoor", "glass wall: map 194"]
        );
        assert_eq!(wrap("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        assert!(wrap("", 4).is_empty());
    }

    #[test]
    fn a_long_body_is_drawn_as_its_outline_turned_with_the_robot() {
        let grid = GridSpec {
            cells: 100,
            cell_m: 0.1,
        };
        let classes = vec![cell_class::FREE; 100 * 100];
        let marks = Marks {
            robot_radius_m: 0.6,
            body_m: Some((1.1, 0.5)),
            path: vec![(-3.0, 0.0), (-1.0, 0.0)],
            ..Marks::default()
        };
        let img = render_map(grid, &classes, &[], &marks);
        // ahead is up: the body's front edge 0.55 m ahead, its side 0.25 m to the left
        let (fx, fy) = pixel(grid, 0.55, 0.1);
        assert_eq!(colour_at(&img, fx, fy), ROBOT);
        let (sx, sy) = pixel(grid, 0.3, 0.25);
        assert_eq!(colour_at(&img, sx, sy), ROBOT);
        // inside the outline, off the heading tick: the cell's own colour
        let (ix, iy) = pixel(grid, -0.3, 0.15);
        assert_eq!(colour_at(&img, ix, iy), FREE);
        // the path behind it
        let (px, py) = pixel(grid, -2.0, 0.0);
        assert_eq!(colour_at(&img, px, py), PATH);
    }
}
