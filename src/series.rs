//! One time-series type and CSV schema for both codes: columns `name[unit]` in SI, rows by
//! step. [`contact_series`] turns raw frames (LIGGGHTS dumps or native state, the same
//! [`Frame`] type) into the channels of a contact case with one function, so both codes'
//! channels are derived by identical arithmetic.

use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::solver::vec3::{cross, dot, V3};
use crate::solver::Frame;
use crate::spec::Case;
use std::path::Path;

/// A table of channels over output steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Column headers after `step`, e.g. `time[s]`, `fn[N]`, `ft_x[N]`.
    pub columns: Vec<String>,
    pub steps: Vec<u64>,
    /// One row per step, `columns.len()` values each.
    pub rows: Vec<Vec<f64>>,
}

/// A named group of columns compared together: a scalar, or the x/y/z components of a vector
/// (its peak is the largest vector magnitude).
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    pub name: String,
    pub unit: String,
    pub cols: Vec<usize>,
}

impl Series {
    fn new() -> Self {
        Series {
            columns: Vec::new(),
            steps: Vec::new(),
            rows: Vec::new(),
        }
    }

    /// Index of a column by full header, e.g. `fn[N]`.
    pub fn col(&self, header: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == header)
    }

    /// The values of one column.
    /// Mean of column `header` over the rows with step in `(w.0, w.1]`; NaN when the column is
    /// missing or the window empty.
    pub fn window_mean(&self, header: &str, w: (u64, u64)) -> f64 {
        let v = self.window_values(header, w).unwrap_or_default();
        v.iter().sum::<f64>() / v.len() as f64
    }

    /// The values of column `header` with step in `(w.0, w.1]`; None when it is missing.
    pub fn window_values(&self, header: &str, w: (u64, u64)) -> Option<Vec<f64>> {
        let c = self.col(header)?;
        Some(
            self.steps
                .iter()
                .zip(&self.rows)
                .filter(|(st, _)| **st > w.0 && **st <= w.1)
                .map(|(_, r)| r[c])
                .collect(),
        )
    }

    pub fn column(&self, header: &str) -> Option<Vec<f64>> {
        let c = self.col(header)?;
        Some(self.rows.iter().map(|r| r[c]).collect())
    }

    /// Channels: `name_x[u]`, `name_y[u]`, `name_z[u]` form one vector channel `name`;
    /// `time[s]` is not a channel.
    pub fn channels(&self) -> Vec<Channel> {
        let mut out: Vec<Channel> = Vec::new();
        for (i, h) in self.columns.iter().enumerate() {
            let (name, unit) = split_header(h);
            if name == "time" {
                continue;
            }
            let base = name
                .strip_suffix("_x")
                .or_else(|| name.strip_suffix("_y"))
                .or_else(|| name.strip_suffix("_z"));
            match base {
                Some(b) => match out.iter_mut().find(|c| c.name == b && c.unit == unit) {
                    Some(c) => c.cols.push(i),
                    None => out.push(Channel {
                        name: b.to_string(),
                        unit: unit.to_string(),
                        cols: vec![i],
                    }),
                },
                None => out.push(Channel {
                    name: name.to_string(),
                    unit: unit.to_string(),
                    cols: vec![i],
                }),
            }
        }
        out
    }

    /// The rows at `steps` (which must all be present), for aligning with a stored
    /// reference that keeps fewer steps.
    pub fn at_steps(&self, steps: &[u64]) -> Result<Series> {
        let mut out = Series {
            columns: self.columns.clone(),
            steps: Vec::with_capacity(steps.len()),
            rows: Vec::with_capacity(steps.len()),
        };
        let mut k = 0;
        for &st in steps {
            while k < self.steps.len() && self.steps[k] < st {
                k += 1;
            }
            if self.steps.get(k) != Some(&st) {
                return Err(Error::Mismatch(format!(
                    "step {st} is missing from the series"
                )));
            }
            out.steps.push(st);
            out.rows.push(self.rows[k].clone());
        }
        Ok(out)
    }

    /// Every `stride`-th row (by step number), plus the last one.
    pub fn decimate(&self, stride: u64) -> Series {
        let last = self.steps.last().copied();
        let keep: Vec<u64> = self
            .steps
            .iter()
            .copied()
            .filter(|s| s.is_multiple_of(stride) || Some(*s) == last)
            .collect();
        self.at_steps(&keep)
            .expect("steps taken from the series itself")
    }

    /// Writes the CSV (`step,<columns>`), atomically, values with 17 significant digits.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        write_atomic(path, &self.csv_bytes(path)?)
    }

    /// The CSV text [`Series::write_csv`] writes (`path` only names the file in errors).
    pub fn csv_bytes(&self, path: &Path) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        let csv_err = |source: csv::Error| Error::Csv {
            path: path.to_path_buf(),
            source,
        };
        let mut header = vec!["step".to_string()];
        header.extend(self.columns.iter().cloned());
        w.write_record(&header).map_err(csv_err)?;
        for (s, r) in self.steps.iter().zip(&self.rows) {
            let mut rec = vec![s.to_string()];
            rec.extend(r.iter().map(|v| format!("{v:e}")));
            w.write_record(&rec).map_err(csv_err)?;
        }
        w.into_inner().map_err(|e| Error::Csv {
            path: path.to_path_buf(),
            source: e.into_error().into(),
        })
    }

    /// Reads a CSV written by [`Series::write_csv`].
    pub fn read_csv(path: &Path) -> Result<Self> {
        let csv_err = |source: csv::Error| Error::Csv {
            path: path.to_path_buf(),
            source,
        };
        let format_err = |msg: String| Error::CsvFormat {
            path: path.to_path_buf(),
            msg,
        };
        let mut r = csv::Reader::from_path(path).map_err(csv_err)?;
        let headers = r.headers().map_err(csv_err)?.clone();
        if headers.get(0) != Some("step") {
            return Err(format_err("first column must be `step`".into()));
        }
        let mut s = Series::new();
        s.columns = headers.iter().skip(1).map(String::from).collect();
        for (ln, rec) in r.records().enumerate() {
            let rec = rec.map_err(csv_err)?;
            let bad = |f: &str| format_err(format!("row {}: bad number {f:?}", ln + 2));
            let step = rec[0].parse().map_err(|_| bad(&rec[0]))?;
            let row: Result<Vec<f64>> = rec
                .iter()
                .skip(1)
                .map(|f| f.parse().map_err(|_| bad(f)))
                .collect();
            s.steps.push(step);
            s.rows.push(row?);
        }
        Ok(s)
    }
}

/// Splits `name[unit]` into (`name`, `unit`).
pub fn split_header(h: &str) -> (&str, &str) {
    match h.find('[') {
        Some(i) => (&h[..i], h[i + 1..].trim_end_matches(']')),
        None => (h, ""),
    }
}

/// The channels of a contact case, from frames:
/// - `fn[N]`: normal force on particle 1, `f1 . n`, `n` = unit vector from particle 2 (or the
///   wall, `+z`) to particle 1; positive = repulsive;
/// - `ft[N]`: tangential force on particle 1, `f1 - fn n`;
/// - `m_roll[N m]`: rolling moment on particle 1, its torque minus the tangential force's
///   torque: `t1 + cr1 (n x ft)`, `cr1 = R1 - overlap/2` (the lever LIGGGHTS uses);
///   for epsd/epsd3 it includes the dashpot;
/// - `shear[m]` and (epsd, epsd2, epsd3) `m_hist[N m]`: the contact history (`shearx..z`,
///   `r_torquex_old..z`) with particle 1 as `i`;
/// - per particle k: `x_k`, `v_k`, `f_k`, `omega_k`, `torque_k`.
///
/// Every frame must hold the case's particles: LIGGGHTS drops an atom that leaves a fixed
/// box without an error, and a dump can be cut short; such a frame is an error naming its
/// step, not a comparison of what is left. No frames at all is an error too.
pub fn contact_series(case: &Case, frames: &[Frame]) -> Result<Series> {
    if frames.is_empty() {
        return Err(Error::Mismatch(format!(
            "{}: no output frames (an empty dump compares nothing)",
            case.name
        )));
    }
    let n = case.particles.len();
    if let Some(bad) = frames.iter().find(|f| f.atoms.len() != n) {
        return Err(Error::Mismatch(format!(
            "{}: step {} holds {} particle(s), the case has {n} (an atom lost from the box, \
             or a cut dump)",
            case.name,
            bad.step,
            bad.atoms.len()
        )));
    }
    let mut s = Series::new();
    let vecs = |s: &mut Series, name: &str, unit: &str| {
        for c in ["x", "y", "z"] {
            s.columns.push(format!("{name}_{c}[{unit}]"));
        }
    };
    s.columns.push("time[s]".into());
    s.columns.push("fn[N]".into());
    vecs(&mut s, "ft", "N");
    vecs(&mut s, "m_roll", "N m");
    vecs(&mut s, "shear", "m");
    let has_hist = case.models.rolling.has_history();
    if has_hist {
        vecs(&mut s, "m_hist", "N m");
    }
    for k in 1..=case.particles.len() {
        vecs(&mut s, &format!("x_{k}"), "m");
        vecs(&mut s, &format!("v_{k}"), "m/s");
        vecs(&mut s, &format!("f_{k}"), "N");
        vecs(&mut s, &format!("omega_{k}"), "rad/s");
        vecs(&mut s, &format!("torque_{k}"), "N m");
    }
    let r1 = case.particles[0].radius;
    for fr in frames {
        let a = &fr.atoms[0];
        let (n, overlap) = match (&case.wall, fr.atoms.get(1)) {
            (Some(w), _) => ([0.0, 0.0, 1.0], r1 - (a.x[2] - w.z)),
            (None, Some(b)) => {
                let d = [a.x[0] - b.x[0], a.x[1] - b.x[1], a.x[2] - b.x[2]];
                let r = dot(d, d).sqrt();
                (
                    [d[0] / r, d[1] / r, d[2] / r],
                    r1 + case.particles[1].radius - r,
                )
            }
            (None, None) => {
                return Err(Error::Mismatch(format!(
                    "{}: one particle and no wall: no contact to measure",
                    case.name
                )))
            }
        };
        let (fn_, ft, mroll) = if fr.touching {
            let fn_ = dot(a.f, n);
            let ft: V3 = [
                a.f[0] - fn_ * n[0],
                a.f[1] - fn_ * n[1],
                a.f[2] - fn_ * n[2],
            ];
            let cr = r1 - 0.5 * overlap;
            let tt = cross(n, ft);
            (
                fn_,
                ft,
                [
                    a.torque[0] + cr * tt[0],
                    a.torque[1] + cr * tt[1],
                    a.torque[2] + cr * tt[2],
                ],
            )
        } else {
            (0.0, [0.0; 3], [0.0; 3])
        };
        let mut row = vec![fr.step as f64 * case.dt, fn_];
        row.extend(ft);
        row.extend(mroll);
        row.extend(fr.history.shear);
        if has_hist {
            row.extend(fr.history.r_torque);
        }
        for at in &fr.atoms {
            for v in [at.x, at.v, at.f, at.omega, at.torque] {
                row.extend(v);
            }
        }
        s.steps.push(fr.step);
        s.rows.push(row);
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_group_vector_components() {
        let s = Series {
            columns: vec![
                "time[s]".into(),
                "fn[N]".into(),
                "ft_x[N]".into(),
                "ft_y[N]".into(),
                "ft_z[N]".into(),
            ],
            steps: vec![],
            rows: vec![],
        };
        let ch = s.channels();
        assert_eq!(ch.len(), 2);
        assert_eq!(ch[1].name, "ft");
        assert_eq!(ch[1].cols, vec![2, 3, 4]);
    }

    #[test]
    fn lost_atom_or_empty_dump_is_an_error_naming_the_step() {
        let case = crate::spec::builtin::builtin_case("rolling_plastic")
            .unwrap()
            .with_rolling(crate::spec::RollingModel::Epsd)
            .validate()
            .unwrap();
        let mut frames = crate::solver::two_body::run(&case.two_body()).unwrap();
        assert!(contact_series(&case, &frames).is_ok());
        let e = contact_series(&case, &[]).unwrap_err().to_string();
        assert!(e.contains("no output frames"), "{e}");
        let k = frames.len() / 2;
        frames[k].atoms.pop();
        let e = contact_series(&case, &frames).unwrap_err().to_string();
        assert!(
            e.contains(&format!("step {} holds 1 particle(s)", frames[k].step)),
            "{e}"
        );
        frames[k].atoms.clear();
        assert!(contact_series(&case, &frames).is_err());
    }

    #[test]
    fn csv_round_trips_exactly() {
        let s = Series {
            columns: vec!["time[s]".into(), "fn[N]".into()],
            steps: vec![0, 1],
            rows: vec![vec![0.0, 1.0 / 3.0], vec![1e-8, -2.5e-300]],
        };
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.csv");
        s.write_csv(&p).unwrap();
        assert_eq!(Series::read_csv(&p).unwrap(), s);
    }
}
