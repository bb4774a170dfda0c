//! Prepared environment emitters other than the constant one — the latitude-longitude map
//! ([`super::envmap`]) and the sun and sky ([`super::sunsky`]) — behind one closed enum, as the
//! light set ([`super::lights`]) samples and evaluates them.

use super::envmap::EnvMap;
use super::sunsky::SunSky;
use crate::math::Color;
use glam::{Vec2, Vec3};

/// A prepared environment emitter (radiance at infinity as a function of direction).
#[derive(Clone, Debug)]
pub enum Environment {
    Map(Box<EnvMap>),
    SunSky(Box<SunSky>),
}

impl Environment {
    /// Radiance arriving from world direction `dir` (unit; a ray leaving the scene along `dir`).
    #[inline]
    pub fn eval(&self, dir: Vec3) -> Color {
        match self {
            Environment::Map(m) => m.eval(dir),
            Environment::SunSky(s) => s.eval(dir),
        }
    }

    /// Sample a world direction towards the emitter: (direction, radiance, solid-angle pdf).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Color, f32)> {
        match self {
            Environment::Map(m) => m.sample(u),
            Environment::SunSky(s) => s.sample(u),
        }
    }

    /// [`Environment::sample`] without the radiance: (direction, solid-angle pdf), `None` in
    /// the same cases. The pdf is [`Environment::pdf`] of the direction, bit for bit (the light
    /// set reads it instead of computing it again).
    #[inline]
    pub fn sample_direction(&self, u: Vec2) -> Option<(Vec3, f32)> {
        match self {
            Environment::Map(m) => m.sample_direction(u),
            Environment::SunSky(s) => s.sample_direction(u),
        }
    }

    /// Solid-angle density of [`Environment::sample`] for world direction `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match self {
            Environment::Map(m) => m.pdf(dir),
            Environment::SunSky(s) => s.pdf(dir),
        }
    }

    /// `∫ L dω` over the sphere, per channel.
    pub fn integral(&self) -> Color {
        match self {
            Environment::Map(m) => m.integral(),
            Environment::SunSky(s) => s.integral(),
        }
    }
}
