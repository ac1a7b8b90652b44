//! The tree as flat arrays of 32-bit words, for a GPU (`fiberlab-gpu` walks exactly these
//! nodes in a compute shader): the two node kinds byte for byte as the CPU walk reads them,
//! the root reference and the leaves' primitive list.
//!
//! # Layout (little-endian words)
//! * An axis-aligned node is 32 words (128 bytes): `origin` (4 × `f32` bits, w = 0), `scale`
//!   (4 × `f32`), the quantized grid `q[row][k]` (6 rows × 8 bytes, byte `k` of row `r` in word
//!   `8 + 2r + k/4` at bit `8·(k % 4)`), the eight child references, the used-slot mask and
//!   three words of padding.
//! * An oriented node is 80 words (320 bytes): the frames `rot[row][col][k]` (9 × 8 signed
//!   bytes, byte `k` of `(row, col)` in word `2(3·row + col) + k/4`), then `lo[row][k]` and
//!   `hi[row][k]` (2 × 24 `f32`, from word 18 and 42), `center` (x, y, z and the radius of its
//!   geometry, word 66), the child references (word 70) and the used-slot mask (word 78).
//! * A child reference: the top four bits are the leaf size (1 to [`MAX_LEAF`]), 0 for an
//!   axis-aligned node, [`FlatBvh::ORIENTED`] for an oriented node, [`FlatBvh::EMPTY`] for an
//!   unused slot; the low 28 bits the node's index among its kind, or the leaf's first entry
//!   in `prims`.
//!
//! [`MAX_LEAF`]: super::MAX_LEAF

use super::{Bvh, ChildRef, EMPTY_SLOT, MAX_REF, ORIENTED, OrientedNode, WideNode};

/// A tree as flat words (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlatBvh {
    /// Axis-aligned nodes, [`FlatBvh::AABB_WORDS`] words each.
    pub aabb: Vec<u32>,
    /// Oriented nodes, [`FlatBvh::ORIENTED_WORDS`] words each.
    pub oriented: Vec<u32>,
    /// The root's child reference ([`FlatBvh::EMPTY`] in the top bits for an empty tree).
    pub root: u32,
    /// The leaves' primitive indices.
    pub prims: Vec<u32>,
}

impl FlatBvh {
    /// Words per axis-aligned node.
    pub const AABB_WORDS: usize = 32;
    /// Words per oriented node.
    pub const ORIENTED_WORDS: usize = 80;
    /// Leaf-size value of a reference to an oriented node.
    pub const ORIENTED: u32 = ORIENTED;
    /// Leaf-size value of an unused slot.
    pub const EMPTY: u32 = EMPTY_SLOT;
    /// Node indices and primitive offsets are below this.
    pub const MAX_INDEX: u32 = MAX_REF;

    /// `r` with its node index moved by `aabb` (axis-aligned) or `oriented` nodes, or its first
    /// primitive by `prims`: for trees appended behind others in one buffer.
    #[must_use]
    pub fn shift(r: u32, aabb: u32, oriented: u32, prims: u32) -> u32 {
        ChildRef::shift(r, aabb, oriented, prims)
    }
}

fn bytes_to_words(bytes: &[u8], out: &mut Vec<u32>) {
    out.extend(bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])));
}

fn aabb_words(n: &WideNode, out: &mut Vec<u32>) {
    let start = out.len();
    out.extend(n.origin.iter().chain(&n.scale).map(|x| x.to_bits()));
    bytes_to_words(n.q.as_flattened(), out);
    out.extend_from_slice(&n.child);
    out.push(n.used);
    out.resize(start + FlatBvh::AABB_WORDS, 0);
}

fn oriented_words(n: &OrientedNode, out: &mut Vec<u32>) {
    let start = out.len();
    let rot: Vec<u8> = n.boxes.rot.as_flattened().as_flattened().iter().map(|&x| x as u8).collect();
    bytes_to_words(&rot, out);
    out.extend(n.boxes.lo.as_flattened().iter().chain(n.boxes.hi.as_flattened()).chain(&n.center).map(|x| x.to_bits()));
    out.extend_from_slice(&n.child);
    out.push(n.used);
    out.resize(start + FlatBvh::ORIENTED_WORDS, 0);
}

impl Bvh {
    /// The tree as flat words (module docs of `bvh::flat`).
    #[must_use]
    pub fn flatten(&self) -> FlatBvh {
        let mut flat = FlatBvh { root: self.root, prims: self.prims.clone(), ..FlatBvh::default() };
        flat.aabb.reserve(self.nodes.aabb.len() * FlatBvh::AABB_WORDS);
        for n in &self.nodes.aabb {
            aabb_words(n, &mut flat.aabb);
        }
        flat.oriented.reserve(self.nodes.oriented.len() * FlatBvh::ORIENTED_WORDS);
        for n in &self.nodes.oriented {
            oriented_words(n, &mut flat.oriented);
        }
        flat
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{Boxes, BuildPrim};
    use crate::test_random::Lcg;

    /// The words hold every field where the module docs say, for both node kinds.
    #[test]
    fn words_hold_the_nodes_fields_where_documented() {
        let mut g = Lcg(4);
        let records: Vec<BuildPrim> = (0..2000)
            .map(|i| {
                let p = (g.vec() - 0.5) * 4.0;
                BuildPrim::segment(p, p + fiberlab_math::DVec3::X * 0.3 + (g.vec() - 0.5) * 0.05, 0.01, i)
            })
            .collect();
        let bvh = Bvh::build_records_with(records, Boxes::Oriented);
        let flat = bvh.flatten();
        assert_eq!(flat.aabb.len(), bvh.nodes.aabb.len() * FlatBvh::AABB_WORDS);
        assert_eq!(flat.oriented.len(), bvh.nodes.oriented.len() * FlatBvh::ORIENTED_WORDS);
        assert!(!bvh.nodes.oriented.is_empty() && !bvh.nodes.aabb.is_empty());
        assert_eq!((flat.root, &flat.prims), (bvh.root, &bvh.prims));
        for (i, n) in bvh.nodes.aabb.iter().enumerate() {
            let w = &flat.aabb[i * FlatBvh::AABB_WORDS..];
            assert_eq!(f32::from_bits(w[1]), n.origin[1]);
            assert_eq!(f32::from_bits(w[6]), n.scale[2]);
            for (r, row) in n.q.iter().enumerate() {
                for (k, &q) in row.iter().enumerate() {
                    assert_eq!((w[8 + 2 * r + k / 4] >> (8 * (k % 4))) as u8, q);
                }
            }
            assert_eq!(&w[20..28], &n.child);
            assert_eq!(w[28], n.used);
        }
        for (i, n) in bvh.nodes.oriented.iter().enumerate() {
            let w = &flat.oriented[i * FlatBvh::ORIENTED_WORDS..];
            for row in 0..3 {
                for col in 0..3 {
                    for k in 0..8 {
                        let byte = (w[2 * (3 * row + col) + k / 4] >> (8 * (k % 4))) as u8 as i8;
                        assert_eq!(byte, n.boxes.rot[row][col][k]);
                    }
                }
                for k in 0..8 {
                    assert_eq!(f32::from_bits(w[18 + 8 * row + k]), n.boxes.lo[row][k]);
                    assert_eq!(f32::from_bits(w[42 + 8 * row + k]), n.boxes.hi[row][k]);
                }
            }
            assert_eq!(f32::from_bits(w[69]), n.center[3]);
            assert_eq!(&w[70..78], &n.child);
            assert_eq!(w[78], n.used);
        }
    }
}
