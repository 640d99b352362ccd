//! Pictures of the map in the paper's colours (Fig. 4 d–f of `mim-lidar-intensity-navigation.txt`):
//! solid cells in white to grey by intensity (brighter is more intense), free space black,
//! passable cells green, glass yellow, cells never observed dark slate; the robot pink with a
//! heading tick, the goal blue. Pure: returns RGB pixels; the caller encodes them.

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

/// What to draw on top of the cells.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Marks {
    /// Robot footprint radius, m (drawn at the centre, heading up).
    pub robot_radius_m: f64,
    /// The goal in the robot frame (x forward, y left), m.
    pub goal: Option<(f64, f64)>,
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
    let (cx, cy) = pixel(grid, 0.0, 0.0);
    img.disc(cx, cy, (marks.robot_radius_m * px_per_m).max(3.0), ROBOT);
    for k in 0..(marks.robot_radius_m * px_per_m * 1.6) as i64 {
        img.put(cx as i64, cy as i64 - k, ROBOT);
    }
    if let Some((gx, gy)) = marks.goal {
        let (px, py) = pixel(grid, gx, gy);
        img.disc(px, py, 5.0, GOAL);
    }
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
}
