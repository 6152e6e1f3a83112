//! Directions the caller gives: finite, non-zero, scaled to unit length without overflow.

use crate::error::{bail, check_finite, Result};
use glam::DVec3;

/// `v` scaled to unit length, for any finite non-zero `v` (huge and tiny components
/// included: it is scaled by its largest component first), or None for the zero vector.
pub fn unit_vector(v: [f64; 3]) -> Option<DVec3> {
    let v = DVec3::from(v);
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    Some((v / m).normalize())
}

pub(super) fn direction(name: &str, v: [f64; 3]) -> Result<DVec3> {
    check_finite(name, &v)?;
    match unit_vector(v) {
        Some(d) => Ok(d),
        None => bail!(ImapErrInvalidArgument, "{name} is the zero vector"),
    }
}

/// The unit component of `r` perpendicular to unit `axis`, or an error naming `name`.
pub(super) fn perpendicular(
    name: &str,
    r: [f64; 3],
    axis: DVec3,
    axis_name: &str,
) -> Result<DVec3> {
    let r = direction(name, r)?;
    let p = r - axis * r.dot(axis);
    if p.length() < 1e-6 {
        bail!(
            ImapErrInvalidArgument,
            "{name} is parallel to {axis_name}: it must give a direction across it"
        );
    }
    Ok(p.normalize())
}
