//! The scene's geometry as the backends receive it: the flat soup (world space) and, for Mitsuba's
//! `shapegroup` + `instance`, prototypes (object-space triangle ranges of the same soup) placed any number
//! of times by instances (an affine `to_world` and its inverse). A prototype's triangles are stored once,
//! whatever the number of its instances (Mitsuba 3: `ShapeGroup` holds the shapes and its own accelerator,
//! `Instance` a reference to it and a transform, src/shapes/instance.cpp).
//!
//! A hit on an instance carries the instance's index in [`Hit::inst`](super::Hit) and the prototype
//! triangle's index in the whole soup in `prim`; a hit on the flat soup carries [`FLAT`]. Rays are
//! transformed into object space by the instance's inverse, the direction unnormalised, so `t` is the world
//! ray's parameter (Mitsuba's `Instance::ray_intersect_preliminary`).

use std::ops::Range;

use glam::Affine3A;

use super::analytic::Analytic;
use crate::math::{Aabb, Ray, Vec3};

/// [`Hit::inst`](super::Hit) of a hit on the flat (not instanced) soup.
pub const FLAT: u32 = u32::MAX;

// An instance costs 144 bytes (`render::memory` counts them): two `Affine3A`s of 64 and the prototype.
const _: () = assert!(size_of::<Instance>() == 144);

/// One placement of a prototype.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Geometry::prototypes`].
    pub prototype: u32,
    pub to_world: Affine3A,
    /// The inverse of `to_world`.
    pub to_object: Affine3A,
}

impl Instance {
    /// The instance of `prototype` at `to_world`; `None` when `to_world` has no finite inverse.
    #[must_use]
    pub fn new(prototype: u32, to_world: Affine3A) -> Option<Self> {
        let to_object = to_world.inverse();
        let finite = to_object.matrix3.to_cols_array().iter().chain(&to_object.translation.to_array()).all(|x| x.is_finite());
        (finite && to_world.matrix3.determinant() != 0.0).then_some(Self { prototype, to_world, to_object })
    }

    /// `ray` in the prototype's object space: the same parameter `t` names the same point.
    #[inline(always)]
    #[must_use]
    pub fn object_ray(&self, ray: &Ray) -> Ray {
        Ray {
            origin: self.to_object.transform_point3(ray.origin),
            dir: self.to_object.transform_vector3(ray.dir),
            t_min: ray.t_min,
            t_max: ray.t_max,
        }
    }

    /// A box holding the object-space box `b` placed in world space (its eight corners), padded by a few
    /// ulps of its coordinates for the rounding of the transform.
    #[must_use]
    pub fn world_bounds(&self, b: Aabb) -> Aabb {
        if b.is_empty() {
            return Aabb::EMPTY;
        }
        let mut w = Aabb::EMPTY;
        for k in 0..8 {
            let c = Vec3::new(if k & 1 == 0 { b.min.x } else { b.max.x }, if k & 2 == 0 { b.min.y } else { b.max.y }, if k & 4 == 0 { b.min.z } else { b.max.z });
            w = w.grow(self.to_world.transform_point3(c));
        }
        let pad = Vec3::splat(8.0 * f32::EPSILON) * w.min.abs().max(w.max.abs()) + Vec3::splat(f32::MIN_POSITIVE);
        Aabb { min: w.min - pad, max: w.max + pad }
    }
}

/// The geometry a backend is built from ([`super::build_accel`]).
#[derive(Clone, Copy, Debug)]
pub struct Geometry<'a> {
    pub positions: &'a [Vec3],
    pub indices: &'a [[u32; 3]],
    /// Triangles `[0, flat)` are the flat soup, in world space.
    pub flat: u32,
    /// Each prototype's triangles (object space), a range of `indices` past `flat`.
    pub prototypes: &'a [Range<u32>],
    pub instances: &'a [Instance],
    /// The analytic primitives (module `analytic`), world space; their hits' `prim` continue the
    /// numbering after the soup's triangles (`indices.len() + k`).
    pub analytic: &'a [Analytic],
}

impl<'a> Geometry<'a> {
    /// A soup without instances.
    #[must_use]
    pub fn soup(positions: &'a [Vec3], indices: &'a [[u32; 3]]) -> Self {
        Self { positions, indices, flat: indices.len() as u32, prototypes: &[], instances: &[], analytic: &[] }
    }

    #[must_use]
    pub fn flat_indices(&self) -> &'a [[u32; 3]] {
        &self.indices[..self.flat as usize]
    }

    #[must_use]
    pub fn prototype_indices(&self, p: usize) -> &'a [[u32; 3]] {
        let r = &self.prototypes[p];
        &self.indices[r.start as usize..r.end as usize]
    }

    /// The object-space box of each prototype.
    #[must_use]
    pub fn prototype_bounds(&self) -> Vec<Aabb> {
        (0..self.prototypes.len())
            .map(|p| self.prototype_indices(p).iter().flatten().fold(Aabb::EMPTY, |b, &i| b.grow(self.positions[i as usize])))
            .collect()
    }

    /// Each instance's world box.
    #[must_use]
    pub fn instance_bounds(&self) -> Vec<Aabb> {
        let proto = self.prototype_bounds();
        self.instances.iter().map(|i| i.world_bounds(proto[i.prototype as usize])).collect()
    }

    /// `prim` of analytic primitive 0.
    #[must_use]
    pub fn first_analytic(&self) -> u32 {
        self.indices.len() as u32
    }

    /// Checks that the prototypes are ranges of the soup past the flat part and that instances name them.
    pub(crate) fn check(&self) -> Result<(), String> {
        let n = self.indices.len() as u32;
        if self.flat > n {
            return Err(format!("{} flat triangles of {n}", self.flat));
        }
        if let Some((p, r)) = self.prototypes.iter().enumerate().find(|(_, r)| r.start < self.flat || r.start > r.end || r.end > n) {
            return Err(format!("prototype {p}'s triangles {r:?} are not a range of the {n} past the {} flat ones", self.flat));
        }
        if let Some(i) = self.instances.iter().position(|i| i.prototype as usize >= self.prototypes.len()) {
            return Err(format!("instance {i} names prototype {} of {}", self.instances[i].prototype, self.prototypes.len()));
        }
        Ok(())
    }
}
