//! What particles are coloured by, and the colours and legend that choice gives: the one
//! mapping the CLI's `--color` and the Python package's `color=` share.

use glam::DVec3;

use crate::{Legend, depth_colors, normal_colors, sigma_colors};

/// What particles are coloured by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coloring {
    /// Their leaf's octree depth ([`depth_colors`], the paper's Fig. 5), with a depth legend.
    Depth,
    /// Their radius σ ([`sigma_colors`]), with a σ legend.
    Sigma,
    /// Their normal ([`normal_colors`]), without a legend.
    Normal,
    /// The colours they carry from the input (a coloured scan's), without a legend.
    Input,
}

impl Coloring {
    /// The colouring named `"depth"`, `"sigma"` or `"normal"`; `None` for any other name.
    ///
    /// ```
    /// use psi_render::Coloring;
    /// assert_eq!(Coloring::from_name("sigma"), Some(Coloring::Sigma));
    /// assert_eq!(Coloring::from_name("red"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<Coloring> {
        match name {
            "depth" => Some(Coloring::Depth),
            "sigma" => Some(Coloring::Sigma),
            "normal" => Some(Coloring::Normal),
            "input" => Some(Coloring::Input),
            _ => None,
        }
    }

    /// The per-particle property this colouring reads (`"depth"`, `"sigma"`, `"normal"` or
    /// `"input"`, the input's colours).
    pub fn name(self) -> &'static str {
        match self {
            Coloring::Depth => "depth",
            Coloring::Sigma => "sigma",
            Coloring::Normal => "normal",
            Coloring::Input => "input",
        }
    }

    /// The colours of N particles (shape N) and their legend (`None` for normals and input
    /// colours), from their `depth` (shape N, levels), `sigma` (shape N, world units),
    /// `normals` (shape N, unit) or the colours `input` they carry (shape N, RGB), whichever
    /// this colouring reads; `None` when that property is absent.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_render::Coloring;
    /// let normals = [DVec3::Z; 2];
    /// let (colors, legend) = Coloring::Depth.colors(Some(&[5.0, 7.0]), None, &normals, None).unwrap();
    /// assert_eq!((colors.len(), legend.unwrap().max), (2, 7.0));
    /// assert!(Coloring::Sigma.colors(Some(&[5.0, 7.0]), None, &normals, None).is_none());
    /// let red = [[255, 0, 0]; 2];
    /// assert_eq!(Coloring::Input.colors(None, None, &normals, Some(&red)).unwrap().0, red);
    /// assert!(Coloring::Input.colors(None, None, &normals, None).is_none());
    /// ```
    pub fn colors(
        self,
        depth: Option<&[f64]>,
        sigma: Option<&[f64]>,
        normals: &[DVec3],
        input: Option<&[[u8; 3]]>,
    ) -> Option<(Vec<[u8; 3]>, Option<Legend>)> {
        match self {
            Coloring::Depth => depth.map(|d| (depth_colors(d), Some(Legend::depth(d)))),
            Coloring::Sigma => sigma.map(|s| (sigma_colors(s), Some(Legend::sigma(s)))),
            Coloring::Normal => Some((normal_colors(normals), None)),
            Coloring::Input => input.map(|c| (c.to_vec(), None)),
        }
    }
}
