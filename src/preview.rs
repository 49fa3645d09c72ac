//! `--preview`: the UV layout of one atlas page drawn as a PNG.
//!
//! What is drawn, back to front: a light checker (one square per 1/16 of the page), every chart
//! filled in its own colour (colours spread by the golden ratio over the hue circle, so
//! neighbouring chart ids differ), each chart's outline (edges used once within the chart) in
//! dark grey, and the page border.
//!
//! Conventions: pixel `(x, y)` covers UV `[x/W, (x+1)/W] × [y/H, (y+1)/H]` and is filled when its
//! centre is inside a triangle; v grows downwards, as glTF's texture coordinates do, so the
//! picture is the texture as an image viewer shows it.
//!
//! Not core (it encodes PNG), but pure: bytes out, no IO.
use crate::atlas::Atlas;

/// Largest side of a preview, pixels; larger pages are drawn scaled down.
pub const MAX_PREVIEW_SIDE_PX: u32 = 4096;

/// Pixel size of a preview of a `width × height` texel page: the page size, scaled down so that
/// neither side exceeds [`MAX_PREVIEW_SIDE_PX`].
pub fn preview_size_px(width_texels: u32, height_texels: u32) -> (u32, u32) {
    let longest = width_texels.max(height_texels).max(1);
    if longest <= MAX_PREVIEW_SIDE_PX {
        (width_texels.max(1), height_texels.max(1))
    } else {
        let s = MAX_PREVIEW_SIDE_PX as f64 / longest as f64;
        (
            ((width_texels as f64 * s).round() as u32).max(1),
            ((height_texels as f64 * s).round() as u32).max(1),
        )
    }
}

/// Draws page `page` of `atlas` at `width_px × height_px` (each clamped to
/// 1..=[`MAX_PREVIEW_SIDE_PX`]) and returns the PNG file's bytes.
pub fn render_preview(atlas: &Atlas, page: u32, width_px: u32, height_px: u32) -> Vec<u8> {
    let w = width_px.clamp(1, MAX_PREVIEW_SIDE_PX) as usize;
    let h = height_px.clamp(1, MAX_PREVIEW_SIDE_PX) as usize;
    let mut rgb = vec![0u8; w * h * 3];
    let cell = (w.max(h) / 16).max(1);
    for y in 0..h {
        for x in 0..w {
            let light = ((x / cell) + (y / cell)) % 2 == 0;
            let c = if light { 0xf4 } else { 0xe2 };
            rgb[(y * w + x) * 3..][..3].copy_from_slice(&[c, c, c]);
        }
    }
    let to_px = |uv: [f32; 2]| [uv[0] as f64 * w as f64, uv[1] as f64 * h as f64];
    // Fill.
    for (f, tri) in atlas.corner_uvs.iter().enumerate() {
        if atlas.face_page.get(f) != Some(&page) {
            continue;
        }
        let color = chart_color(atlas.face_chart.get(f).copied().unwrap_or(0));
        fill_triangle(&mut rgb, w, h, tri.map(to_px), color);
    }
    // Outlines: edges that occur once within their chart (by exact UV bits).
    let mut edges: Vec<(u32, [u32; 2], [u32; 2])> = Vec::new();
    for (f, tri) in atlas.corner_uvs.iter().enumerate() {
        if atlas.face_page.get(f) != Some(&page) {
            continue;
        }
        let chart = atlas.face_chart.get(f).copied().unwrap_or(0);
        for k in 0..3 {
            let a = tri[k].map(f32::to_bits);
            let b = tri[(k + 1) % 3].map(f32::to_bits);
            edges.push((chart, a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i == 1 {
            let (_, a, b) = edges[i];
            let p = to_px(a.map(f32::from_bits));
            let q = to_px(b.map(f32::from_bits));
            draw_line(&mut rgb, w, h, p, q, [0x30, 0x30, 0x30]);
        }
        i = j;
    }
    // Page border.
    for x in 0..w {
        set(&mut rgb, w, h, x as i64, 0, [0, 0, 0]);
        set(&mut rgb, w, h, x as i64, h as i64 - 1, [0, 0, 0]);
    }
    for y in 0..h {
        set(&mut rgb, w, h, 0, y as i64, [0, 0, 0]);
        set(&mut rgb, w, h, w as i64 - 1, y as i64, [0, 0, 0]);
    }
    encode_png(&rgb, w as u32, h as u32)
}

/// A saturated, mid-bright colour for chart `chart` (golden-ratio hue steps).
fn chart_color(chart: u32) -> [u8; 3] {
    let hue = (chart as f64 * 0.618_033_988_749_895).fract() * 6.0;
    let (s, v) = (0.55, 0.9);
    let i = hue.floor() as u32 % 6;
    let f = hue - hue.floor();
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    let (r, g, b) = match i {
        0 => (v, t, p),
        1 => (q, v, p),
        2 => (p, v, t),
        3 => (p, q, v),
        4 => (t, p, v),
        _ => (v, p, q),
    };
    [r, g, b].map(|c| (c * 255.0).round() as u8)
}

fn set(rgb: &mut [u8], w: usize, h: usize, x: i64, y: i64, c: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
        let i = (y as usize * w + x as usize) * 3;
        rgb[i..i + 3].copy_from_slice(&c);
    }
}

/// Fills the pixels whose centre is inside the triangle (either orientation).
fn fill_triangle(rgb: &mut [u8], w: usize, h: usize, p: [[f64; 2]; 3], c: [u8; 3]) {
    if p.iter().flatten().any(|x| !x.is_finite()) {
        return;
    }
    let min_x = p.iter().map(|q| q[0]).fold(f64::INFINITY, f64::min);
    let max_x = p.iter().map(|q| q[0]).fold(f64::NEG_INFINITY, f64::max);
    let min_y = p.iter().map(|q| q[1]).fold(f64::INFINITY, f64::min);
    let max_y = p.iter().map(|q| q[1]).fold(f64::NEG_INFINITY, f64::max);
    let x0 = (min_x - 0.5).ceil().max(0.0) as usize;
    let x1 = ((max_x - 0.5).floor()).min(w as f64 - 1.0);
    let y0 = (min_y - 0.5).ceil().max(0.0) as usize;
    let y1 = ((max_y - 0.5).floor()).min(h as f64 - 1.0);
    if x1 < 0.0 || y1 < 0.0 {
        return;
    }
    let edge = |a: [f64; 2], b: [f64; 2], x: f64, y: f64| {
        (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
    };
    let area = edge(p[0], p[1], p[2][0], p[2][1]);
    if area == 0.0 {
        return;
    }
    for y in y0..=(y1 as usize) {
        for x in x0..=(x1 as usize) {
            let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
            let e = [
                edge(p[0], p[1], cx, cy),
                edge(p[1], p[2], cx, cy),
                edge(p[2], p[0], cx, cy),
            ];
            let inside = if area > 0.0 {
                e.iter().all(|&v| v >= 0.0)
            } else {
                e.iter().all(|&v| v <= 0.0)
            };
            if inside {
                set(rgb, w, h, x as i64, y as i64, c);
            }
        }
    }
}

/// A one-pixel line (DDA), clipped to the image.
fn draw_line(rgb: &mut [u8], w: usize, h: usize, p: [f64; 2], q: [f64; 2], c: [u8; 3]) {
    if p.iter().chain(&q).any(|x| !x.is_finite()) {
        return;
    }
    let steps = (q[0] - p[0])
        .abs()
        .max((q[1] - p[1]).abs())
        .ceil()
        .clamp(1.0, 1e5) as usize;
    for s in 0..=steps {
        let t = s as f64 / steps as f64;
        let x = p[0] + (q[0] - p[0]) * t;
        let y = p[1] + (q[1] - p[1]) * t;
        set(rgb, w, h, x.floor() as i64, y.floor() as i64, c);
    }
}

fn encode_png(rgb: &[u8], w: u32, h: u32) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Fast);
        // Writing into a Vec cannot fail for a buffer of the declared size.
        if let Ok(mut writer) = encoder.write_header() {
            let _ = writer.write_image_data(rgb);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atlas::{AtlasReport, PipelineStats};

    fn atlas_of(corner_uvs: Vec<[[f32; 2]; 3]>, face_chart: Vec<u32>) -> Atlas {
        let n = corner_uvs.len();
        Atlas {
            corner_uvs,
            face_chart,
            chart_page: vec![0, 0],
            face_page: vec![0; n],
            num_pages: 1,
            stats: PipelineStats::default(),
            report: AtlasReport::default(),
        }
    }

    fn decode(png_bytes: &[u8]) -> (u32, u32, Vec<u8>) {
        let decoder = png::Decoder::new(png_bytes);
        let mut reader = decoder.read_info().expect("png header");
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).expect("png frame");
        buf.truncate(info.buffer_size());
        (info.width, info.height, buf)
    }

    #[test]
    fn draws_charts_in_their_colours_with_outlines_and_border() {
        // Chart 0: a triangle in the top-left quarter; chart 1: one in the bottom-right.
        let atlas = atlas_of(
            vec![
                [[0.05, 0.05], [0.45, 0.05], [0.05, 0.45]],
                [[0.95, 0.95], [0.55, 0.95], [0.95, 0.55]],
            ],
            vec![0, 1],
        );
        let (w, h, rgb) = decode(&render_preview(&atlas, 0, 64, 64));
        assert_eq!((w, h), (64, 64));
        let px = |x: usize, y: usize| {
            [
                rgb[(y * 64 + x) * 3],
                rgb[(y * 64 + x) * 3 + 1],
                rgb[(y * 64 + x) * 3 + 2],
            ]
        };
        assert_eq!(
            px(10, 10),
            chart_color(0),
            "inside chart 0 (top-left, v down)"
        );
        assert_eq!(px(55, 55), chart_color(1), "inside chart 1");
        assert_ne!(chart_color(0), chart_color(1));
        assert_eq!(px(0, 30), [0, 0, 0], "page border");
        assert_eq!(
            px(3, 3),
            px(3, 3).map(|_| px(3, 3)[0]),
            "background is grey"
        );
        assert_eq!(px(10, 3), [0x30; 3], "outline along v = 0.05");
        assert_eq!(
            px(40, 20),
            [px(40, 20)[0]; 3],
            "outside both charts: checker"
        );
    }

    #[test]
    fn interior_edges_are_not_outlined_and_other_pages_are_skipped() {
        // Two triangles of one chart sharing the diagonal: no line along it.
        let mut atlas = atlas_of(
            vec![
                [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9]],
                [[0.1, 0.1], [0.9, 0.9], [0.1, 0.9]],
            ],
            vec![0, 0],
        );
        let (_, _, rgb) = decode(&render_preview(&atlas, 0, 100, 100));
        let at = |x: usize, y: usize| {
            [
                rgb[(y * 100 + x) * 3],
                rgb[(y * 100 + x) * 3 + 1],
                rgb[(y * 100 + x) * 3 + 2],
            ]
        };
        assert_eq!(at(50, 50), chart_color(0), "diagonal not drawn");
        atlas.face_page = vec![1, 1];
        let (_, _, rgb) = decode(&render_preview(&atlas, 0, 100, 100));
        assert_ne!(
            [
                rgb[(50 * 100 + 50) * 3],
                rgb[(50 * 100 + 50) * 3 + 1],
                rgb[(50 * 100 + 50) * 3 + 2]
            ],
            chart_color(0),
            "faces of page 1 are not drawn on page 0"
        );
    }

    #[test]
    fn preview_size_caps_the_longest_side() {
        assert_eq!(preview_size_px(1024, 512), (1024, 512));
        assert_eq!(preview_size_px(16384, 8192), (4096, 2048));
    }
}
