//! A region's bound on its cells: at the exact count the region decides what an unbounded
//! one decides (the whole build's cells, by the exactness of regions), one fewer stops it.

use psi_mpu::{Mpu, MpuError, MpuFrame, MpuParams, Region, RegionPoints, fit_region};
use psi_octree::Monitor;
use psi_shapes::AnalyticShape;

#[test]
fn a_region_decides_up_to_its_bound_and_stops_past_it() {
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.3,
    }
    .sample(4000, 11);
    let params = MpuParams::paper();
    let frame = MpuFrame::for_points(&points, &params).unwrap();
    let whole = Mpu::build(&points, &params).unwrap();
    for key in [[0, 0, 0], [1, 1, 0]] {
        let region = Region::tile(1, key);
        let fit = |max_cells| {
            let input = RegionPoints {
                max_cells,
                ..RegionPoints::new(&points, points.len())
            };
            fit_region(&input, &frame, &params, &region, &Monitor::silent())
        };
        let free = fit(None).unwrap();
        let n = free.cells.len();
        // The oracle: the whole build's cells under the tile.
        let under = |d: u8, k: [u32; 3]| d >= 1 && (0..3).all(|a| k[a] >> (d - 1) == key[a]);
        let cells = whole.octree().cells();
        let expected = cells.iter().filter(|c| under(c.depth, c.key)).count();
        assert_eq!(n, expected, "tile {key:?}");
        let at = fit(Some(n)).unwrap();
        assert_eq!(at.cells, free.cells);
        for max in [n - 1, n / 3, 0] {
            assert_eq!(fit(Some(max)).unwrap_err(), MpuError::TooManyCells { max });
        }
    }
}
