//! The paper's Tables 1 and 2 (Proença, Jorge, Sousa; 3.6 GHz Pentium IV), and the model files
//! that stand for its models (`../shared/models/MANIFEST.md`).

/// One row of the paper's Table 1.
pub(crate) struct PaperRow {
    pub(crate) model: &'static str,
    pub(crate) file: &'static str,
    pub(crate) stand_in: Option<&'static str>,
    pub(crate) dataset_points: usize,
    pub(crate) particles: usize,
    pub(crate) init_seconds: f64,
    pub(crate) simulate_seconds: f64,
}

/// Table 1: 20 iterations, one particle per octree cell.
pub(crate) const TABLE1: [PaperRow; 7] = [
    PaperRow {
        model: "bunny",
        file: "bunny.ply",
        stand_in: None,
        dataset_points: 69451,
        particles: 10000,
        init_seconds: 0.3,
        simulate_seconds: 29.0,
    },
    PaperRow {
        model: "cow",
        file: "cow.ply",
        stand_in: None,
        dataset_points: 92864,
        particles: 8334,
        init_seconds: 0.4,
        simulate_seconds: 31.0,
    },
    PaperRow {
        model: "horse",
        file: "horse.ply",
        stand_in: None,
        dataset_points: 96966,
        particles: 6668,
        init_seconds: 0.4,
        simulate_seconds: 17.0,
    },
    PaperRow {
        model: "igea",
        file: "igea.ply",
        stand_in: None,
        dataset_points: 268686,
        particles: 13665,
        init_seconds: 1.1,
        simulate_seconds: 42.0,
    },
    PaperRow {
        model: "armadillo",
        file: "armadillo.ply",
        stand_in: Some("lower-resolution Armadillo, 1x Loop subdivision"),
        dataset_points: 345944,
        particles: 28360,
        init_seconds: 1.5,
        simulate_seconds: 176.0,
    },
    PaperRow {
        model: "dragon",
        file: "dragon_standin_stanford_480076.ply",
        stand_in: Some("Stanford Dragon decimated to 480 076 faces"),
        dataset_points: 480076,
        particles: 26984,
        init_seconds: 2.3,
        simulate_seconds: 112.0,
    },
    PaperRow {
        model: "david",
        file: "david_standin_stanford_dragon.ply",
        stand_in: Some("full-resolution Stanford Dragon"),
        dataset_points: 827181,
        particles: 59994,
        init_seconds: 3.7,
        simulate_seconds: 789.0,
    },
];

/// Table 2: 10 iterations (ours, as the paper reports them).
pub(crate) const TABLE2: [(&str, usize, f64, f64); 2] =
    [("bunny", 10000, 0.3, 15.0), ("david", 59994, 3.7, 433.0)];

/// Table 2's bottom half: Levet et al. as the paper quotes them (model, implicit, particles,
/// init seconds or None, simulation seconds or total).
pub(crate) const LEVET: [(&str, &str, usize, Option<f64>, f64); 2] = [
    ("bunny", "VIS", 12388, None, 313.0),
    ("ellipsoid", "analytic", 55748, Some(25.0), 589.0),
];
