//! The heat map as a picture: viridis false colour and a legend strip with
//! the minimum and maximum cost in a small bitmap font. Application code:
//! the library's [`HeatMap`] holds the counts only.

use packtrace::render::{HeatMap, Rgb8};

/// The map in false colour (viridis, linear from [`HeatMap::min`] to
/// [`HeatMap::max`]) with a legend strip below it: the colour bar between
/// the minimum, printed at the left, and the maximum, printed at the
/// right, in a 5 x 7 pixel font scaled with the image width.
pub fn heat_image(h: &HeatMap) -> Rgb8 {
    let (lo, hi) = (h.min(), h.max());
    let span = (hi - lo).max(1) as f32;
    let mut data: Vec<u8> = h
        .counts
        .iter()
        .flat_map(|&c| viridis((c - lo) as f32 / span))
        .collect();
    let legend = legend(h.width, lo, hi);
    data.extend_from_slice(&legend.data);
    Rgb8 {
        width: h.width,
        height: h.height + legend.height,
        data,
    }
}

/// Height in pixels of the legend strip [`heat_image`] adds below a
/// map of the given width: 13 font pixels (7 for digits, 3 of margin above
/// and below), each `max(1, width / 256)` image pixels tall.
pub fn legend_height(width: u32) -> u32 {
    13 * legend_scale(width)
}

fn legend_scale(width: u32) -> u32 {
    (width / 256).max(1)
}

/// Viridis (van der Walt and Smith, matplotlib 2015) at 9 stops, linearly
/// interpolated in sRGB bytes; `x` is clamped to `[0, 1]`.
fn viridis(x: f32) -> [u8; 3] {
    const STOPS: [[u8; 3]; 9] = [
        [68, 1, 84],
        [71, 44, 122],
        [59, 81, 139],
        [44, 113, 142],
        [33, 144, 141],
        [39, 173, 129],
        [92, 200, 99],
        [170, 220, 50],
        [253, 231, 37],
    ];
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let pos = x * (STOPS.len() - 1) as f32;
    let i = (pos as usize).min(STOPS.len() - 2);
    let f = pos - i as f32;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    std::array::from_fn(|c| (a[c] as f32 + (b[c] as f32 - a[c] as f32) * f).round() as u8)
}

/// Digits 0-9 in a 5 x 7 font, one byte per row, bit 4 the leftmost pixel.
const DIGITS: [[u8; 7]; 10] = [
    [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
    [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
    [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
    [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
    [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
    [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
    [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
    [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
    [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
    [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
];
const LEGEND_BG: [u8; 3] = [24, 24, 24];
const LEGEND_INK: [u8; 3] = [235, 235, 235];

/// The legend strip: `min` at the left, the colour bar, `max` at the
/// right. Labels are left out when the strip is too narrow for them.
fn legend(width: u32, min: u32, max: u32) -> Rgb8 {
    let k = legend_scale(width);
    let height = legend_height(width);
    let mut img = Rgb8 {
        width,
        height,
        data: LEGEND_BG.repeat(width as usize * height as usize),
    };
    let (lo, hi) = (min.to_string(), max.to_string());
    let text_w = |s: &str| (6 * s.len() as u32 - 1) * k;
    let pad = 3 * k;
    let (mut bar_x0, mut bar_x1) = (0, width);
    let room = text_w(&lo) + text_w(&hi) + 4 * pad + 8 * k;
    if width >= room {
        draw_text(&mut img, pad, pad, k, &lo);
        draw_text(&mut img, width - pad - text_w(&hi), pad, k, &hi);
        bar_x0 = 2 * pad + text_w(&lo);
        bar_x1 = width - 2 * pad - text_w(&hi);
    }
    let span = (bar_x1 - bar_x0).saturating_sub(1).max(1) as f32;
    for x in bar_x0..bar_x1 {
        let c = viridis((x - bar_x0) as f32 / span);
        for y in pad..pad + 7 * k {
            put(&mut img, x, y, c);
        }
    }
    img
}

fn put(img: &mut Rgb8, x: u32, y: u32, c: [u8; 3]) {
    if x < img.width && y < img.height {
        let i = 3 * (y as usize * img.width as usize + x as usize);
        img.data[i..i + 3].copy_from_slice(&c);
    }
}

/// Draw decimal digits with their top-left corner at `(x, y)`, each font
/// pixel `k x k` image pixels, one font pixel between glyphs.
fn draw_text(img: &mut Rgb8, x: u32, y: u32, k: u32, text: &str) {
    for (g, ch) in text.bytes().enumerate() {
        let Some(glyph) = ch.checked_sub(b'0').and_then(|d| DIGITS.get(d as usize)) else {
            continue;
        };
        let gx = x + g as u32 * 6 * k;
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..5 {
                if bits >> (4 - col) & 1 == 1 {
                    for dy in 0..k {
                        for dx in 0..k {
                            put(img, gx + col * k + dx, y + row as u32 * k + dy, LEGEND_INK);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legend_height_scales_with_width() {
        assert_eq!(
            (legend_height(64), legend_height(512), legend_height(1024)),
            (13, 26, 52)
        );
    }

    #[test]
    fn heat_image_is_viridis_with_the_legend_below() {
        let h = HeatMap {
            width: 64,
            height: 2,
            counts: (0..128).collect(),
        };
        let img = heat_image(&h);
        assert_eq!((img.width, img.height), (64, 2 + legend_height(64)));
        // darkest purple at the minimum, yellow at the maximum
        assert_eq!(img.pixel(0, 0), [68, 1, 84]);
        assert_eq!(img.pixel(63, 1), [253, 231, 37]);
    }

    #[test]
    fn viridis_ends_and_middle() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(0.5), [33, 144, 141]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(viridis(f32::NAN), [68, 1, 84]);
    }

    /// The legend prints the labels' digits: decode them back.
    #[test]
    fn legend_labels_read_back() {
        let img = legend(300, 7, 1234);
        let read = |x0: u32, len: usize| -> String {
            (0..len)
                .map(|g| {
                    let glyph: [u8; 7] = std::array::from_fn(|row| {
                        (0..5).fold(0u8, |b, col| {
                            let on =
                                img.pixel(x0 + (g as u32 * 6 + col), 3 + row as u32) == LEGEND_INK;
                            b | (on as u8) << (4 - col)
                        })
                    });
                    let d = DIGITS.iter().position(|d| *d == glyph).expect("a digit");
                    char::from(b'0' + d as u8)
                })
                .collect()
        };
        assert_eq!(read(3, 1), "7");
        assert_eq!(read(300 - 3 - 23, 4), "1234");
        // the bar runs from dark to bright between the labels
        assert_eq!(img.pixel(3 + 5 + 3, 5), viridis(0.0));
        assert_eq!(img.pixel(300 - 3 - 23 - 3 - 1, 5), viridis(1.0));
    }

    #[test]
    fn narrow_legend_is_a_bare_bar() {
        let img = legend(8, 0, 123_456);
        assert_eq!(img.pixel(0, 3), viridis(0.0));
        assert_eq!(img.pixel(7, 3), viridis(1.0));
    }
}
