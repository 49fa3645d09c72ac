//! Typed element ids and per-element data.
//!
//! Purpose: make it impossible to index vertex data with a face id. Every id is a `u32` newtype
//! (4 bytes: a 1M-triangle mesh has 3M half-edges, and ids appear in every connectivity array).
//!
//! Invariants:
//! - `FaceId(i)` is input triangle `i`, always (the build never reorders or drops faces).
//! - `CornerId(3 * f + k)` is corner `k` of face `f`, in input corner order.
//! - `HalfedgeId` shares the corner numbering: half-edge `3 * f + k` runs from corner `k` to
//!   corner `(k + 1) % 3` of face `f`, so the outgoing half-edges of a vertex are exactly its corners.
//!
//! Ids are plain values: an id from one mesh used on another mesh is a programming error, and
//! mesh accessors panic on an out-of-range id exactly like slice indexing does.
use std::fmt;
use std::marker::PhantomData;
use std::ops::{Index, IndexMut};

/// Implemented by every typed id, so that [`IdVec`] can be indexed by it.
pub trait ElementId: Copy + Eq + Ord + fmt::Debug {
    /// The id as an index into a dense per-element array.
    fn index(self) -> usize;
    /// The id with the given index. Panics if `index` does not fit in `u32` (a programming error:
    /// mesh building rejects inputs whose ids would not fit).
    fn from_index(index: usize) -> Self;
}

macro_rules! typed_id {
    ($(#[$doc:meta])* $name:ident, $prefix:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
        pub struct $name(pub u32);

        impl $name {
            /// The id as a `usize`, for indexing dense arrays.
            #[inline]
            pub fn index(self) -> usize {
                self.0 as usize
            }
        }

        impl ElementId for $name {
            #[inline]
            fn index(self) -> usize {
                self.0 as usize
            }
            #[inline]
            fn from_index(index: usize) -> Self {
                match u32::try_from(index) {
                    Ok(i) => $name(i),
                    Err(_) => panic!(concat!(stringify!($name), " index {} does not fit in u32"), index),
                }
            }
        }

        impl fmt::Debug for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, concat!($prefix, "{}"), self.0)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, concat!($prefix, "{}"), self.0)
            }
        }
    };
}

typed_id!(
    /// A vertex of the built mesh (after welding and repair splits). Displayed as `v12`.
    VertexId,
    "v"
);
typed_id!(
    /// A face of the built mesh; face `i` is input triangle `i`. Displayed as `f12`.
    FaceId,
    "f"
);
typed_id!(
    /// A half-edge; `HalfedgeId(3f + k)` runs from corner `k` to corner `k + 1` of face `f`.
    /// Displayed as `h12`.
    HalfedgeId,
    "h"
);
typed_id!(
    /// A corner (face, slot); `CornerId(3f + k)` is corner `k` of face `f`. Displayed as `c12`.
    CornerId,
    "c"
);
typed_id!(
    /// A connected component of the glued mesh, numbered by its lowest face id. Displayed as `k3`.
    ComponentId,
    "k"
);

impl FaceId {
    /// Corner `k` (0, 1 or 2) of this face. Panics if `k > 2`.
    #[inline]
    pub fn corner(self, k: usize) -> CornerId {
        assert!(k < 3, "a triangle has corners 0, 1 and 2, not {k}");
        CornerId(self.0 * 3 + k as u32)
    }

    /// Half-edge `k` of this face: from corner `k` to corner `(k + 1) % 3`. Panics if `k > 2`.
    #[inline]
    pub fn halfedge(self, k: usize) -> HalfedgeId {
        assert!(k < 3, "a triangle has half-edges 0, 1 and 2, not {k}");
        HalfedgeId(self.0 * 3 + k as u32)
    }
}

impl CornerId {
    /// The face this corner belongs to.
    #[inline]
    pub fn face(self) -> FaceId {
        FaceId(self.0 / 3)
    }
    /// The slot (0, 1 or 2) of this corner within its face.
    #[inline]
    pub fn slot(self) -> usize {
        (self.0 % 3) as usize
    }
    /// The outgoing half-edge that starts at this corner (same number).
    #[inline]
    pub fn halfedge(self) -> HalfedgeId {
        HalfedgeId(self.0)
    }
}

impl HalfedgeId {
    /// The face on the left of this half-edge.
    #[inline]
    pub fn face(self) -> FaceId {
        FaceId(self.0 / 3)
    }
    /// The corner this half-edge starts from (same number).
    #[inline]
    pub fn corner(self) -> CornerId {
        CornerId(self.0)
    }
    /// The next half-edge in the same face (counter-clockwise for a front-facing triangle).
    #[inline]
    pub fn next(self) -> HalfedgeId {
        let base = self.0 - self.0 % 3;
        HalfedgeId(base + (self.0 % 3 + 1) % 3)
    }
    /// The previous half-edge in the same face.
    #[inline]
    pub fn prev(self) -> HalfedgeId {
        let base = self.0 - self.0 % 3;
        HalfedgeId(base + (self.0 % 3 + 2) % 3)
    }
}

/// A dense array of per-element data indexed by a typed id: `FaceData<f64>`, `VertexData<[f64; 3]>`.
#[derive(Clone, PartialEq)]
pub struct IdVec<I, T> {
    data: Vec<T>,
    _id: PhantomData<fn(I) -> I>,
}

/// Per-face data, indexed by [`FaceId`].
pub type FaceData<T> = IdVec<FaceId, T>;
/// Per-vertex data, indexed by [`VertexId`].
pub type VertexData<T> = IdVec<VertexId, T>;
/// Per-corner data (e.g. UVs, which live per corner because seams split vertices), indexed by [`CornerId`].
pub type CornerData<T> = IdVec<CornerId, T>;
/// Per-half-edge data, indexed by [`HalfedgeId`].
pub type HalfedgeData<T> = IdVec<HalfedgeId, T>;

impl<I: ElementId, T> IdVec<I, T> {
    /// Wraps a plain vector; element `i` belongs to id `i`.
    pub fn from_vec(data: Vec<T>) -> Self {
        Self {
            data,
            _id: PhantomData,
        }
    }
    /// `len` copies of `value`.
    pub fn filled(len: usize, value: T) -> Self
    where
        T: Clone,
    {
        Self::from_vec(vec![value; len])
    }
    /// Number of elements.
    pub fn len(&self) -> usize {
        self.data.len()
    }
    /// True when there are no elements.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    /// The element for `id`, or `None` if `id` is out of range.
    pub fn get(&self, id: I) -> Option<&T> {
        self.data.get(id.index())
    }
    /// `(id, value)` pairs in id order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = (I, &T)> + '_ {
        self.data
            .iter()
            .enumerate()
            .map(|(i, t)| (I::from_index(i), t))
    }
    /// The underlying slice, in id order.
    pub fn as_slice(&self) -> &[T] {
        &self.data
    }
    /// The underlying vector, in id order.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }
}

impl<I: ElementId, T> Index<I> for IdVec<I, T> {
    type Output = T;
    #[inline]
    fn index(&self, id: I) -> &T {
        &self.data[id.index()]
    }
}

impl<I: ElementId, T> IndexMut<I> for IdVec<I, T> {
    #[inline]
    fn index_mut(&mut self, id: I) -> &mut T {
        &mut self.data[id.index()]
    }
}

impl<I, T: fmt::Debug> fmt::Debug for IdVec<I, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.data.fmt(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corner_and_halfedge_numbering_follow_the_face() {
        let f = FaceId(7);
        assert_eq!(f.corner(0), CornerId(21));
        assert_eq!(f.corner(2).face(), f);
        assert_eq!(f.corner(2).slot(), 2);
        assert_eq!(f.halfedge(1), HalfedgeId(22));
        assert_eq!(f.halfedge(0).next(), f.halfedge(1));
        assert_eq!(f.halfedge(2).next(), f.halfedge(0));
        assert_eq!(f.halfedge(0).prev(), f.halfedge(2));
        for k in 0..3 {
            let h = f.halfedge(k);
            assert_eq!(h.next().next().next(), h);
            assert_eq!(h.prev().next(), h);
            assert_eq!(h.face(), f);
            assert_eq!(h.corner().halfedge(), h);
        }
    }

    #[test]
    fn id_vec_indexes_by_typed_id() {
        let mut d: FaceData<i32> = FaceData::filled(3, 0);
        d[FaceId(1)] = 5;
        assert_eq!(d.as_slice(), &[0, 5, 0]);
        assert_eq!(d.get(FaceId(3)), None);
        assert_eq!(d.len(), 3);
        assert!(!d.is_empty());
        let pairs: Vec<_> = d.iter().map(|(f, v)| (f, *v)).collect();
        assert_eq!(pairs[1], (FaceId(1), 5));
        assert_eq!(format!("{}", FaceId(4)), "f4");
        assert_eq!(format!("{:?}", VertexId(2)), "v2");
        assert_eq!(d.into_vec(), vec![0, 5, 0]);
        let v: VertexData<u8> = VertexData::from_vec(vec![1, 2]);
        assert_eq!(v[VertexId(1)], 2);
    }

    #[test]
    #[should_panic(expected = "corners 0, 1 and 2")]
    fn corner_slot_out_of_range_panics() {
        let _ = FaceId(0).corner(3);
    }
}
