//! Cell decisions keyed by cell: what a build of a region decided for each of its cells, so
//! that the decisions of many regions (tiles) can be put together into one MPU
//! ([`crate::BuildOptions::known_cells`]).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::select_fit::LeafFit;

/// One cell's decision in a build: whether it splits, the radius its fit used, and a leaf's
/// local function.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellDecision {
    pub(crate) split: bool,
    /// The fit radius R1 (world units).
    pub(crate) fit_radius: f64,
    /// A leaf's fit (`None` for a cell that splits).
    pub(crate) leaf: Option<LeafFit>,
}

impl CellDecision {
    /// Whether the cell splits.
    pub fn split(&self) -> bool {
        self.split
    }

    /// The radius R1 its fit read points within (world units).
    pub fn fit_radius(&self) -> f64 {
        self.fit_radius
    }
}

/// A cell's address: depth (root 0) and integer key at that depth (see `psi_octree::Cell`).
pub type CellAddress = (u8, [u32; 3]);

/// Decisions of cells by address, in address order (depth, then key), whatever order they
/// were added in.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CellTable {
    cells: BTreeMap<CellAddress, CellDecision>,
}

impl CellTable {
    /// Cells in the table.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether the table holds no cell.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The decision for the cell at `depth` with `key`.
    pub fn get(&self, depth: u8, key: [u32; 3]) -> Option<&CellDecision> {
        self.cells.get(&(depth, key))
    }

    /// The cells and their decisions, in address order.
    pub fn iter(&self) -> impl Iterator<Item = (&CellAddress, &CellDecision)> {
        self.cells.iter()
    }

    /// Adds `decision` for the cell at `address`. Returns the address back when the table
    /// already holds a different decision for it (two regions disagreeing is a bug to report,
    /// not to paper over); an equal one is accepted.
    pub fn insert(
        &mut self,
        address: CellAddress,
        decision: CellDecision,
    ) -> Result<(), CellAddress> {
        match self.cells.get(&address) {
            Some(d) if *d != decision => Err(address),
            Some(_) => Ok(()),
            None => {
                self.cells.insert(address, decision);
                Ok(())
            }
        }
    }

    /// Adds every decision of `other` ([`CellTable::insert`]); stops at the first conflict.
    pub fn merge(&mut self, other: CellTable) -> Result<(), CellAddress> {
        for (a, d) in other.cells {
            self.insert(a, d)?;
        }
        Ok(())
    }
}
