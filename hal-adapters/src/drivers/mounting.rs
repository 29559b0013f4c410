//! The mounting rotation from the sensor's axes to the body axes (forward-right-down).
//!
//! Only the nominal mounting lives here: a signed axis permutation or a fixed rotation matrix.
//! Calibrated misalignment, scale factors and biases belong in `nav-core`.

/// One of the sensor's axes, with a sign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SignedAxis {
    /// Sensor +x.
    PlusX,
    /// Sensor -x.
    MinusX,
    /// Sensor +y.
    PlusY,
    /// Sensor -y.
    MinusY,
    /// Sensor +z.
    PlusZ,
    /// Sensor -z.
    MinusZ,
}

impl SignedAxis {
    /// `(axis index, sign)`.
    const fn parts(self) -> (usize, f32) {
        match self {
            SignedAxis::PlusX => (0, 1.0),
            SignedAxis::MinusX => (0, -1.0),
            SignedAxis::PlusY => (1, 1.0),
            SignedAxis::MinusY => (1, -1.0),
            SignedAxis::PlusZ => (2, 1.0),
            SignedAxis::MinusZ => (2, -1.0),
        }
    }
}

/// The rotation `c_s_b` from sensor axes to body axes: `v_b = c_s_b v_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mounting {
    /// Row-major direction-cosine matrix, sensor to body [-].
    pub c_s_b: [[f32; 3]; 3],
}

impl Default for Mounting {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Mounting {
    /// Sensor axes are the body axes (forward-right-down).
    pub const IDENTITY: Mounting = Mounting {
        c_s_b: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    /// Sensor axes forward-left-up (the axes PX4's drivers assume for the ADIS1647x and the
    /// ICM-42688-P) to body forward-right-down: `(x, -y, -z)`.
    pub const FLU_TO_FRD: Mounting = Mounting {
        c_s_b: [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]],
    };

    /// A signed axis permutation: body axis `i` (forward, right, down) is `axes[i]` of the
    /// sensor. `None` unless every sensor axis is used once and the result is a proper rotation
    /// (determinant +1, no mirror).
    pub fn from_axes(axes: [SignedAxis; 3]) -> Option<Mounting> {
        let mut c_s_b = [[0.0f32; 3]; 3];
        let mut used = [false; 3];
        for (row, axis) in c_s_b.iter_mut().zip(axes) {
            let (index, sign) = axis.parts();
            if used[index] {
                return None;
            }
            used[index] = true;
            row[index] = sign;
        }
        let m = Mounting { c_s_b };
        (m.determinant() > 0.0).then_some(m)
    }

    /// A rotation matrix `c_s_b` (row-major, sensor to body). Not checked: it must be
    /// orthonormal with determinant +1.
    pub const fn from_matrix(c_s_b: [[f32; 3]; 3]) -> Mounting {
        Mounting { c_s_b }
    }

    /// `v_b = c_s_b v_s`.
    pub fn to_body(&self, v_s: [f32; 3]) -> [f32; 3] {
        let c = &self.c_s_b;
        [0, 1, 2].map(|i| c[i][0] * v_s[0] + c[i][1] * v_s[1] + c[i][2] * v_s[2])
    }

    /// `v_s = c_s_b^T v_b` (the inverse rotation).
    pub fn to_sensor(&self, v_b: [f32; 3]) -> [f32; 3] {
        let c = &self.c_s_b;
        [0, 1, 2].map(|j| c[0][j] * v_b[0] + c[1][j] * v_b[1] + c[2][j] * v_b[2])
    }

    /// The rotation from the body axes of a driver mounted by `applied` to those of `self`:
    /// `c_s_b c_applied^T`, for a run whose installation (`self`, e.g. a configuration frame's)
    /// is not the one the driver applies. Exact for signed axis permutations.
    pub fn relative_to(&self, applied: &Mounting) -> Mounting {
        let (a, b) = (&self.c_s_b, &applied.c_s_b);
        Mounting {
            c_s_b: [0, 1, 2].map(|i| {
                [0, 1, 2].map(|j| a[i][0] * b[j][0] + a[i][1] * b[j][1] + a[i][2] * b[j][2])
            }),
        }
    }

    /// Nine numbers, row by row, comma-separated (`c_s_b`); `None` unless there are exactly
    /// nine and every one is finite. Not checked for a rotation: [`Self::is_rotation`].
    pub fn parse_rows(text: &str) -> Option<Mounting> {
        let mut c_s_b = [[0.0f32; 3]; 3];
        let mut parts = text.split(',');
        for v in c_s_b.iter_mut().flatten() {
            *v = parts
                .next()
                .and_then(|p| p.trim().parse::<f32>().ok())
                .filter(|x| x.is_finite())?;
        }
        parts.next().is_none().then_some(Mounting { c_s_b })
    }

    /// True when `c_s_b` is orthonormal with determinant +1, each within `tol` (NaN refused).
    pub fn is_rotation(&self, tol: f32) -> bool {
        let c = &self.c_s_b;
        let dot = |i: usize, j: usize| (0..3).map(|k| c[i][k] * c[j][k]).sum::<f32>();
        let orthonormal = (0..3).all(|i| {
            (0..3).all(|j| {
                let want = if i == j { 1.0 } else { 0.0 };
                (dot(i, j) - want).abs() <= tol
            })
        });
        orthonormal && (self.determinant() - 1.0).abs() <= tol
    }

    fn determinant(&self) -> f32 {
        let c = &self.c_s_b;
        c[0][0] * (c[1][1] * c[2][2] - c[1][2] * c[2][1])
            - c[0][1] * (c[1][0] * c[2][2] - c[1][2] * c[2][0])
            + c[0][2] * (c[1][0] * c[2][1] - c[1][1] * c[2][0])
    }

    /// `c_s_b` with every element multiplied by `scale` (computed once, so that a sample costs
    /// one matrix product from raw counts to body-axis SI units).
    pub(crate) fn scaled(&self, scale: f32) -> ScaledRotation {
        ScaledRotation {
            m: self.c_s_b.map(|row| row.map(|c| c * scale)),
        }
    }
}

/// `c_s_b` times a sensitivity: raw device counts (sensor axes) to SI units in body axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ScaledRotation {
    m: [[f32; 3]; 3],
}

impl ScaledRotation {
    /// `m raw` (9 multiplications, 6 additions).
    #[inline]
    pub(crate) fn apply(&self, raw: [i32; 3]) -> [f32; 3] {
        let v = raw.map(|r| r as f32);
        let m = &self.m;
        [
            m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
            m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_permutations() {
        use SignedAxis::*;
        let m = Mounting::from_axes([PlusX, MinusY, MinusZ]).unwrap();
        assert_eq!(m, Mounting::FLU_TO_FRD);
        assert_eq!(m.to_body([1.0, 2.0, 3.0]), [1.0, -2.0, -3.0]);
        // Body forward = sensor y, right = sensor -x, down = sensor z.
        let m = Mounting::from_axes([PlusY, MinusX, PlusZ]).unwrap();
        assert_eq!(m.to_body([1.0, 2.0, 3.0]), [2.0, -1.0, 3.0]);
        assert_eq!(m.to_sensor(m.to_body([1.0, 2.0, 3.0])), [1.0, 2.0, 3.0]);
        // Repeated axis, mirror.
        assert!(Mounting::from_axes([PlusX, PlusX, PlusZ]).is_none());
        assert!(Mounting::from_axes([PlusX, PlusY, MinusZ]).is_none());
    }

    /// A sensor installed as `m` read by a driver that applies `applied`: turning its output by
    /// `m.relative_to(applied)` gives the body vector back, exactly for axis permutations and
    /// within rounding for a general rotation.
    #[test]
    fn a_run_mounting_undoes_the_drivers() {
        use SignedAxis::*;
        let m = Mounting::from_axes([PlusY, MinusX, PlusZ]).unwrap();
        let v_b = [0.25, -1.5, 9.75];
        for applied in [Mounting::IDENTITY, Mounting::FLU_TO_FRD, m] {
            let read = applied.to_body(m.to_sensor(v_b));
            assert_eq!(m.relative_to(&applied).to_body(read), v_b);
        }
        assert_eq!(m.relative_to(&m), Mounting::IDENTITY);
        let (s, c) = 0.3f32.sin_cos();
        let tilted = Mounting::from_matrix([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]);
        let back = tilted
            .relative_to(&Mounting::FLU_TO_FRD)
            .to_body(Mounting::FLU_TO_FRD.to_body(tilted.to_sensor(v_b)));
        for (a, b) in back.iter().zip(v_b) {
            assert!((a - b).abs() < 1e-5, "{back:?}");
        }
    }

    #[test]
    fn scaled_rotation_applies_scale_and_axes() {
        let s = Mounting::FLU_TO_FRD.scaled(0.5);
        assert_eq!(s.apply([2, 4, -6]), [1.0, -2.0, 3.0]);
    }
}
