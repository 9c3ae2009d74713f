//! The solvers a benchmark compares: one type, [`SolverKind`], holds each one's name in the
//! results, its settings, its colour in the plots and whether `results.json` lists it.

use std::fmt;
use std::str::FromStr;

use serde::{Serialize, Serializer};
use shrad::dispersive::DispersiveOptions;
use shrad::grid::GridOptions;
use shrad::solver::SolverChoice;

/// The solvers compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SolverKind {
    /// Uniform grid, G = 5, cube maps 128 (the paper's baseline; sets the same-time budget).
    Grid5,
    /// Uniform grid, G = 4, cube maps 128.
    Grid4,
    /// Uniform grid, G = 5, cube maps at the dispersive default's probe resolution (32): the
    /// like-for-like cost of the grid, beside the paper's.
    Grid5DefaultRes,
    /// Dispersive, shrad's default ([`DispersiveOptions::improved`]).
    Dispersive,
    /// Dispersive, the paper's preset ([`DispersiveOptions::paper`]).
    Paper,
}

impl SolverKind {
    /// All of them, grid5 first (it sets the same-time budget).
    pub const ALL: [SolverKind; 5] = [
        SolverKind::Grid5,
        SolverKind::Grid4,
        SolverKind::Grid5DefaultRes,
        SolverKind::Dispersive,
        SolverKind::Paper,
    ];

    /// Name in the results.
    pub fn label(self) -> &'static str {
        match self {
            SolverKind::Grid4 => "grid4",
            SolverKind::Grid5 => "grid5",
            SolverKind::Grid5DefaultRes => "grid5-r32",
            SolverKind::Dispersive => "dispersive",
            SolverKind::Paper => "paper",
        }
    }

    /// The solver settings.
    pub fn choice(self) -> SolverChoice {
        match self {
            SolverKind::Grid4 => SolverChoice::Grid(GridOptions::paper(4)),
            SolverKind::Grid5 => SolverChoice::Grid(GridOptions::paper(5)),
            SolverKind::Grid5DefaultRes => SolverChoice::Grid(GridOptions {
                cube_res: DispersiveOptions::improved().cube_res,
                ..GridOptions::paper(5)
            }),
            SolverKind::Dispersive => SolverChoice::Dispersive(DispersiveOptions::improved()),
            SolverKind::Paper => SolverChoice::Dispersive(DispersiveOptions::paper()),
        }
    }

    /// A uniform probe grid (updates every probe every frame).
    pub fn is_grid(self) -> bool {
        matches!(self.choice(), SolverChoice::Grid(_))
    }

    /// One of the four solvers the issue's `results.json` lists (the others are extras,
    /// reported in `report.json` and the Markdown).
    pub fn in_results_json(self) -> bool {
        self != SolverKind::Grid5DefaultRes
    }

    /// Its colour in every plot (RGB).
    pub fn colour(self) -> (u8, u8, u8) {
        match self {
            SolverKind::Grid4 => (230, 120, 0),
            SolverKind::Grid5 => (30, 60, 200),
            SolverKind::Grid5DefaultRes => (100, 170, 230),
            SolverKind::Dispersive => (200, 0, 120),
            SolverKind::Paper => (40, 150, 40),
        }
    }
}

impl fmt::Display for SolverKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

/// Parse a label (`grid5`, `grid4`, `grid5-r32`, `dispersive`, `paper`); the error lists them.
impl FromStr for SolverKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        SolverKind::ALL
            .into_iter()
            .find(|k| k.label() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = SolverKind::ALL.iter().map(|k| k.label()).collect();
                format!("unknown solver {s}; known: {}", names.join(", "))
            })
    }
}

/// Serialised as its label, as `results.json` has always written it.
impl Serialize for SolverKind {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.label())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn like_for_like_grid_label_names_the_default_resolution() {
        let SolverChoice::Grid(g) = SolverKind::Grid5DefaultRes.choice() else {
            panic!("not a grid");
        };
        assert_eq!(
            SolverKind::Grid5DefaultRes.label(),
            format!("grid5-r{}", g.cube_res)
        );
    }

    #[test]
    fn labels_parse_back_and_unknown_ones_are_listed() {
        for k in SolverKind::ALL {
            assert_eq!(k.label().parse::<SolverKind>(), Ok(k));
        }
        let e = "grid6".parse::<SolverKind>().unwrap_err();
        assert!(e.contains("grid6") && e.contains("grid5-r32"), "{e}");
        assert_eq!(SolverKind::ALL.iter().filter(|k| k.is_grid()).count(), 3);
    }
}
