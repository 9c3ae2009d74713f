//! Spherical harmonics for shrad (to be written).
