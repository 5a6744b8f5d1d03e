//! TEMPORARY scaffold so that the tree compiles while the real BVH is written on its own branch.
//! Replaced wholesale by the SAH BVH; never merged to main in this form.
use super::brute::BruteForce;
use crate::math::Vec3;

pub struct Bvh;
impl Bvh {
    #[allow(clippy::new_ret_no_self)]
    pub fn build(positions: &[Vec3], indices: &[[u32; 3]]) -> BruteForce {
        BruteForce::new(positions, indices)
    }
}
