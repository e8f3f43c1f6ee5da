//! Coordinates of the solution curve's parameter space, `(t, a, b)`: the camera depth t and the
//! barycentric coordinates (a, b) of the refraction point.
//!
//! For one triangle and one camera segment the zeros of `f(t, a, b)` form a curve in this space;
//! the solver, the edge crossings and the interval search all work with its points and tangents.
//! Naming the components keeps "which index is t" out of the arithmetic. The component-wise
//! operations are written out in a fixed order (t, a, b), each component computed as
//! `x + h·d` or `x + θ·(y − x)`, so results are reproducible to the bit.

/// A point of parameter space `(t, a, b)`, or a direction in it (a tangent of the curve, a
/// continuation step).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CurvePoint {
    /// The depth along the camera segment.
    pub t: f64,
    /// Barycentric a of the refraction point.
    pub a: f64,
    /// Barycentric b of the refraction point.
    pub b: f64,
}

impl CurvePoint {
    /// The point `(t, a, b)`.
    #[inline]
    pub const fn new(t: f64, a: f64, b: f64) -> Self {
        CurvePoint { t, a, b }
    }

    /// The point from `[t, a, b]`.
    #[inline]
    pub const fn from_array(x: [f64; 3]) -> Self {
        CurvePoint {
            t: x[0],
            a: x[1],
            b: x[2],
        }
    }

    /// `[t, a, b]`.
    #[inline]
    pub const fn to_array(self) -> [f64; 3] {
        [self.t, self.a, self.b]
    }

    /// `self + h·dir`, component by component.
    #[inline]
    pub fn step(self, h: f64, dir: CurvePoint) -> CurvePoint {
        CurvePoint {
            t: self.t + h * dir.t,
            a: self.a + h * dir.a,
            b: self.b + h * dir.b,
        }
    }

    /// `self + θ·(other − self)`, component by component.
    #[inline]
    pub fn toward(self, other: CurvePoint, theta: f64) -> CurvePoint {
        CurvePoint {
            t: self.t + theta * (other.t - self.t),
            a: self.a + theta * (other.a - self.a),
            b: self.b + theta * (other.b - self.b),
        }
    }

    /// `self − other`, component by component.
    #[inline]
    pub fn minus(self, other: CurvePoint) -> CurvePoint {
        CurvePoint {
            t: self.t - other.t,
            a: self.a - other.a,
            b: self.b - other.b,
        }
    }
}

/// A sign of a quantity along the curve, ±1: the label of a branch (the sign of
/// `N̂s·(J_a×J_b)`, which flips at a fold) or a direction of travel along the oriented tangent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sign {
    /// +1.
    Plus,
    /// −1.
    Minus,
}

impl Sign {
    /// The sign of `x` as [`f64::signum`] gives it (so +0 is `Plus` and −0 is `Minus`); None
    /// for NaN.
    #[inline]
    pub fn of(x: f64) -> Option<Sign> {
        let s = x.signum();
        if s == 1.0 {
            Some(Sign::Plus)
        } else if s == -1.0 {
            Some(Sign::Minus)
        } else {
            None
        }
    }

    /// ±1.0.
    #[inline]
    pub fn value(self) -> f64 {
        match self {
            Sign::Plus => 1.0,
            Sign::Minus => -1.0,
        }
    }

    /// The sign of the product.
    #[inline]
    pub fn times(self, other: Sign) -> Sign {
        if self == other {
            Sign::Plus
        } else {
            Sign::Minus
        }
    }
}
