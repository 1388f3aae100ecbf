//! Distance along the surface to the nearest crack.
