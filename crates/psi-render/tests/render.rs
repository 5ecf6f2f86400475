//! The renderers against geometry whose picture is known: a sphere of splats is a disk of the
//! fitted radius, a near splat hides a far one, a cube covers its projected area; colour map
//! ends, legends, determinism.

use glam::DVec3;
use psi_render::{
    Backfaces, Camera, Legend, MISSING, Pixmap, Ramp, RenderParams, SplatStyle, View, depth_colors,
    normal_colors, render_mesh, render_splats, scalar_colors, side_by_side, sigma_colors,
};

const WHITE: [u8; 4] = [255; 4];

/// `n` points spread evenly over the unit sphere (a Fibonacci lattice).
fn sphere(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

fn rgba(p: &Pixmap, x: u32, y: u32) -> [u8; 4] {
    let c = p.pixel(x, y).unwrap().demultiply();
    [c.red(), c.green(), c.blue(), c.alpha()]
}

/// Pixels that differ from the background, weighted by how much (so anti-aliased edges count
/// by their coverage).
fn covered_area(p: &Pixmap, background: [u8; 4], region: impl Fn(u32, u32) -> bool) -> f64 {
    let mut area = 0.0;
    for y in 0..p.height() {
        for x in 0..p.width() {
            if !region(x, y) {
                continue;
            }
            let c = rgba(p, x, y);
            let diff = (0..3)
                .map(|k| (f64::from(c[k]) - f64::from(background[k])).abs())
                .fold(0.0, f64::max);
            area += (diff / 40.0).min(1.0);
        }
    }
    area
}

fn small(size: u32) -> RenderParams {
    RenderParams {
        size,
        margin: 0.1,
        ..RenderParams::standard()
    }
}

#[test]
fn a_sphere_of_splats_is_a_disk_of_the_fitted_radius() {
    let p = sphere(4000);
    // Neighbours are about sqrt(4 pi / 4000) = 0.056 apart: disks of 0.06 close the surface.
    let radius = vec![0.06; p.len()];
    let colors = vec![[40, 90, 200]; p.len()];
    for view in [View::Front, View::Side, View::Top, View::Iso] {
        let params = RenderParams { view, ..small(400) };
        let image = render_splats(&p, &p, &colors, &radius, &params).unwrap();
        let camera = Camera::fit(view, p.iter().copied(), [0.0, 0.0, 400.0, 400.0], 0.1);
        let expected = camera.pixels_per_unit(); // the unit sphere's projected radius
        assert!((expected - 160.0).abs() < 2.0, "{view:?}: {expected}");
        let area = covered_area(&image, WHITE, |_, _| true);
        let measured = (area / std::f64::consts::PI).sqrt();
        assert!(
            (measured - expected).abs() < 2.5,
            "{view:?}: disk radius {measured:.2} px, expected {expected:.2}"
        );
        // No holes: everything well inside the disk is covered.
        for y in 0..400 {
            for x in 0..400 {
                let d =
                    ((x as f64 + 0.5 - 200.0).powi(2) + (y as f64 + 0.5 - 200.0).powi(2)).sqrt();
                if d < expected - 4.0 {
                    assert_ne!(rgba(&image, x, y), WHITE, "{view:?}: hole at ({x}, {y})");
                } else if d > expected + 4.0 {
                    assert_eq!(rgba(&image, x, y), WHITE, "{view:?}: paint at ({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn a_near_splat_hides_a_far_one_whatever_the_input_order() {
    let near = DVec3::new(0.0, 0.0, 1.0);
    let far = DVec3::new(0.0, 0.0, -1.0);
    let (red, green) = ([220, 0, 0], [0, 200, 0]);
    let params = RenderParams {
        bounds: Some([DVec3::splat(-2.0), DVec3::splat(2.0)]),
        ..small(100)
    };
    let a = render_splats(
        &[near, far],
        &[DVec3::Z; 2],
        &[red, green],
        &[0.5, 0.7],
        &params,
    )
    .unwrap();
    let b = render_splats(
        &[far, near],
        &[DVec3::Z; 2],
        &[green, red],
        &[0.7, 0.5],
        &params,
    )
    .unwrap();
    assert_eq!(a.data(), b.data());
    let c = rgba(&a, 50, 50);
    assert!(
        c[0] > 150 && c[1] < 20,
        "centre {c:?} is not the near red splat"
    );
    // The far green splat is larger: its rim shows around the red one.
    let rim = rgba(&a, 50, 50 + 12);
    assert!(rim[1] > 120 && rim[0] < 20, "rim {rim:?}");
}

#[test]
fn back_faces_are_darker_or_culled() {
    let p = [DVec3::ZERO];
    let params = small(60);
    let front = render_splats(&p, &[DVec3::Z], &[[200, 200, 200]], &[1.0], &params).unwrap();
    let back = render_splats(&p, &[DVec3::NEG_Z], &[[200, 200, 200]], &[1.0], &params).unwrap();
    assert!(rgba(&back, 30, 30)[0] < rgba(&front, 30, 30)[0]);
    let culled = RenderParams {
        backfaces: Backfaces::Cull,
        ..params
    };
    let none = render_splats(&p, &[DVec3::NEG_Z], &[[200, 200, 200]], &[1.0], &culled).unwrap();
    assert!(none.pixels().iter().all(|c| c.demultiply().red() == 255));
}

#[test]
fn dots_show_only_the_visible_particles() {
    // Two parallel sheets facing the viewer: red dots in front, green dots behind.
    let mut positions = Vec::new();
    let mut colors = Vec::new();
    for (z, color) in [(0.5, [230, 0, 0]), (-0.5, [0, 200, 0])] {
        // The hidden sheet lies within the front one's outline.
        let (count, offset) = if z > 0.0 { (20, 0.0) } else { (19, 0.025) };
        for i in 0..count {
            for j in 0..count {
                positions.push(DVec3::new(
                    i as f64 * 0.05 + offset,
                    j as f64 * 0.05 + offset,
                    z,
                ));
                colors.push(color);
            }
        }
    }
    let params = RenderParams {
        style: SplatStyle::Dots {
            dot: 0.4,
            surface: [200, 200, 200],
        },
        splat_scale: 1.5,
        ..small(200)
    };
    let normals = vec![DVec3::Z; positions.len()];
    let image = render_splats(
        &positions,
        &normals,
        &colors,
        &vec![0.025; positions.len()],
        &params,
    )
    .unwrap();
    let (mut red, mut green) = (0, 0);
    for c in image.pixels() {
        let c = c.demultiply();
        if c.red() > 120 && c.green() < 60 {
            red += 1;
        }
        if c.green() > 100 && c.red() < 60 {
            green += 1;
        }
    }
    assert!(red > 1000, "{red} red pixels");
    assert_eq!(green, 0, "the hidden sheet's dots are drawn");
}

#[test]
fn color_maps_run_from_green_to_deep_red_and_handle_odd_values() {
    let c = depth_colors(&[3.0, 9.0, 6.0, f64::NAN]);
    assert_eq!(c[0], Ramp::Depth.color(0.0));
    assert_eq!(c[1], Ramp::Depth.color(1.0));
    assert_eq!(c[2], Ramp::Depth.color(0.5));
    assert_eq!(c[3], MISSING);
    let (shallow, deep) = (c[0], c[1]);
    assert!(
        shallow[1] > 2 * shallow[0] && shallow[1] > 2 * shallow[2],
        "{shallow:?} is not green"
    );
    assert!(
        deep[0] > 3 * deep[1] && deep[0] > 3 * deep[2] && deep[0] < 200,
        "{deep:?} is not deep red"
    );
    // Equal depths: the middle colour.
    assert_eq!(depth_colors(&[4.0, 4.0]), vec![Ramp::Depth.color(0.5); 2]);
    let s = sigma_colors(&[1e-3, 4e-3]);
    assert_eq!(
        s,
        vec![Ramp::Sequential.color(0.0), Ramp::Sequential.color(1.0)]
    );
    let lightness = |c: [u8; 3]| u32::from(c[0]) + u32::from(c[1]) + u32::from(c[2]);
    let ramp: Vec<u32> = (0..=10)
        .map(|k| lightness(Ramp::Sequential.color(k as f64 / 10.0)))
        .collect();
    assert!(
        ramp.windows(2).all(|w| w[0] < w[1]),
        "sequential lightness {ramp:?}"
    );
    assert_eq!(
        scalar_colors(&[-1.0, 2.0, f64::INFINITY], Ramp::Depth, 0.0, 1.0),
        vec![Ramp::Depth.color(0.0), Ramp::Depth.color(1.0), MISSING]
    );
    assert_eq!(
        normal_colors(&[DVec3::NEG_Y, DVec3::ZERO, DVec3::NAN]),
        vec![[128, 0, 128], MISSING, MISSING]
    );
}

#[test]
fn the_same_input_gives_the_same_bytes_and_bad_values_are_skipped() {
    let p = sphere(1500);
    let depth: Vec<f64> = p.iter().map(|q| (5.0 + 3.0 * q.y.abs()).round()).collect();
    let params = RenderParams {
        view: View::Iso,
        legend: Some(Legend::depth(&depth)),
        style: SplatStyle::Dots {
            dot: 0.5,
            surface: [210, 210, 210],
        },
        ..small(256)
    };
    let colors = depth_colors(&depth);
    let radius = vec![0.08; p.len()];
    let png = |p: &[DVec3], c: &[[u8; 3]], r: &[f64]| {
        render_splats(p, p, c, r, &params)
            .unwrap()
            .encode_png()
            .unwrap()
    };
    let first = png(&p, &colors, &radius);
    assert_eq!(first, png(&p, &colors, &radius));
    // A NaN position and a zero radius are skipped and change nothing.
    let mut p2 = p.clone();
    p2.push(DVec3::new(f64::NAN, 0.0, 0.0));
    p2.push(DVec3::new(5.0, 5.0, 5.0));
    let mut c2 = colors.clone();
    c2.extend([[0, 0, 0]; 2]);
    let mut r2 = radius.clone();
    r2.extend([0.1, 0.0]);
    assert_eq!(first, png(&p2, &c2, &r2));
}

#[test]
fn the_legend_sits_in_its_strip_and_shows_the_ramp_ends() {
    let p = sphere(2000);
    let depth: Vec<f64> = p.iter().map(|q| (6.0 + 2.0 * q.y).round()).collect();
    let params = RenderParams {
        legend: Some(Legend::depth(&depth)),
        ..small(400)
    };
    let image =
        render_splats(&p, &p, &depth_colors(&depth), &vec![0.07; p.len()], &params).unwrap();
    let exact = |color: [u8; 3]| {
        image
            .pixels()
            .iter()
            .filter(|c| {
                let c = c.demultiply();
                [c.red(), c.green(), c.blue()] == color
            })
            .count()
    };
    // The bar's end blocks, unshaded.
    assert!(exact(Ramp::Depth.color(0.0)) > 100);
    assert!(exact(Ramp::Depth.color(1.0)) > 100);
    // Along the equator: the sphere, a white gap, then the bar (the model is fitted left of
    // the legend strip, not under it).
    let painted: Vec<bool> = (0..400).map(|x| rgba(&image, x, 200) != WHITE).collect();
    let start = painted.iter().position(|&p| p).unwrap();
    let end = start + painted[start..].iter().position(|&p| !p).unwrap();
    let bar = end + painted[end..].iter().position(|&p| p).unwrap();
    assert!(
        bar >= end + 5,
        "sphere ends at {end}, legend starts at {bar}"
    );
    assert!(
        (start + end) / 2 < 190,
        "sphere {start}..{end} is not shifted left"
    );
}

/// The cube [-1, 1]^3 as 12 outward triangles.
fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let v: Vec<DVec3> = (0..8)
        .map(|k| {
            DVec3::new(
                if k & 1 == 0 { -1.0 } else { 1.0 },
                if k & 2 == 0 { -1.0 } else { 1.0 },
                if k & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1], // z = -1
        [4, 5, 7, 6], // z = +1
        [0, 1, 5, 4], // y = -1
        [2, 6, 7, 3], // y = +1
        [0, 4, 6, 2], // x = -1
        [1, 3, 7, 5], // x = +1
    ];
    let f = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    (v, f)
}

#[test]
fn a_cube_covers_its_projected_area() {
    let (v, f) = cube();
    // Outward normals.
    for t in &f {
        let [a, b, c] = t.map(|i| v[i as usize]);
        assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
    }
    for (view, projected) in [(View::Front, 4.0), (View::Iso, 4.0 * 3f64.sqrt())] {
        let params = RenderParams { view, ..small(200) };
        let image = render_mesh(&v, &f, &params).unwrap();
        let s =
            Camera::fit(view, v.iter().copied(), [0.0, 0.0, 200.0, 200.0], 0.1).pixels_per_unit();
        let expected = projected * s * s;
        let area = covered_area(&image, WHITE, |_, _| true);
        assert!(
            (area / expected - 1.0).abs() < 0.02,
            "{view:?}: {area:.0} px, expected {expected:.0}"
        );
        // Flat grey: the centre pixel is neutral.
        let c = rgba(&image, 100, 100);
        assert!(
            c[0].abs_diff(c[1]) < 12 && c[1].abs_diff(c[2]) < 12 && c[0] < 250,
            "{c:?}"
        );
    }
    // Seen from the front only the +z face shows: one shade across the whole square.
    let image = render_mesh(&v, &f, &small(200)).unwrap();
    let centre = rgba(&image, 100, 100);
    for (x, y) in [(30, 30), (170, 170), (30, 170), (100, 25)] {
        assert_eq!(rgba(&image, x, y), centre, "({x}, {y})");
    }
}

#[test]
fn panels_are_put_side_by_side_with_captions() {
    let a = render_splats(
        &[DVec3::ZERO],
        &[DVec3::Z],
        &[[0, 0, 200]],
        &[1.0],
        &small(120),
    )
    .unwrap();
    let row = side_by_side(&[(&a, "UNIFORM"), (&a, "ADAPTIVE")], WHITE).unwrap();
    assert!(row.width() > 240 && row.width() < 260);
    assert!(row.height() > 120 && row.height() < 150);
    // Caption ink above the panels.
    let band = row.height() - 120;
    assert!(covered_area(&row, WHITE, |_, y| y < band) > 50.0);
    assert!(side_by_side(&[], WHITE).is_err());
}
