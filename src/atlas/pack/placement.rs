//! [`Placement`], the position the page searches choose for a chart: the horizon search
//! ([`super::horizon`]) and the hole search ([`super::hole`]) both return it.

/// A chosen position: orientation index and the canvas position of the orientation's grid
/// origin (top-left of `D`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Placement {
    /// Index into the chart's orientations.
    pub orientation: usize,
    /// Canvas column of the grid origin.
    pub x: i32,
    /// Canvas row of the grid origin.
    pub y: i32,
}
