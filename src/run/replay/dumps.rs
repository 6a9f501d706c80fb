//! LIGGGHTS' dumps of a replay window: atoms, touching pairs and particle-triangle contacts,
//! read at 17 digits into a recorded state and per-contact values.

use crate::deck::shear::{REPLAY_ATOMS, REPLAY_PAIRS, REPLAY_WALLS};
use crate::error::Result;
use crate::liggghts::dump_atoms;
pub(super) use crate::liggghts::{dump_rows, parse_err};
use crate::solver::contact::ContactHistory;
use crate::solver::shear::replay::RecordedState;
use crate::solver::vec3::V3;
use std::collections::BTreeMap;
use std::path::Path;

/// One parsed dump step.
pub(super) struct Dumped {
    pub(super) state: RecordedState,
    /// (id1 - 1, id2 - 1) -> force, torque on id1, history, periodic flag.
    pub(super) pairs: BTreeMap<(u32, u32), (V3, V3, ContactHistory, bool)>,
    /// (atom - 1, mesh, triangle) -> force, torque, history.
    pub(super) walls: BTreeMap<(u32, u8, u32), (V3, V3, ContactHistory)>,
}

pub(super) fn v3(r: &[f64], at: usize) -> V3 {
    [r[at], r[at + 1], r[at + 2]]
}

pub(super) fn hist(r: &[f64], at: usize, n: usize) -> ContactHistory {
    ContactHistory {
        shear: v3(r, at),
        r_torque: if n == 6 { v3(r, at + 3) } else { [0.0; 3] },
    }
}

pub(super) fn read_dumped(
    dir: &Path,
    step: u64,
    atoms: usize,
    n_hist: usize,
    ntri: [usize; 2],
) -> Result<Dumped> {
    let pa = dir.join(format!("{REPLAY_ATOMS}{step}.dump"));
    let rows = dump_atoms(&pa, step, 19, atoms)?;
    let mut st = RecordedState {
        step,
        ..Default::default()
    };
    for r in &rows {
        st.x.push(v3(r, 1));
        st.v.push(v3(r, 7));
        st.omega.push(v3(r, 10));
        st.f.push(v3(r, 13));
        st.torque.push(v3(r, 16));
    }
    let ncol = 9 + n_hist;
    let pp = dir.join(format!("{REPLAY_PAIRS}{step}.dump"));
    let mut pairs = BTreeMap::new();
    for r in dump_rows(&pp, step, ncol)? {
        let (a, b) = (r[0] as usize, r[1] as usize);
        if a == 0 || b == 0 || a > atoms || b > atoms || a == b {
            return Err(parse_err(
                &pp,
                format!("pair ids {a} {b} outside 1..={atoms}"),
            ));
        }
        let key = ((a - 1) as u32, (b - 1) as u32);
        let h = hist(&r, 9, n_hist);
        st.pairs.insert(key, h);
        pairs.insert(key, (v3(&r, 3), v3(&r, 6), h, r[2] != 0.0));
    }
    let pw = dir.join(format!("{REPLAY_WALLS}{step}.dump"));
    let mut walls = BTreeMap::new();
    for r in dump_rows(&pw, step, ncol)? {
        let (m, t, a) = (r[0] as usize, r[1] as usize, r[2] as usize);
        if m > 1 || t >= ntri[m.min(1)] || a == 0 || a > atoms {
            return Err(parse_err(
                &pw,
                format!("wall contact mesh {m} triangle {t} atom {a} does not exist"),
            ));
        }
        let h = hist(&r, 9, n_hist);
        st.walls.push(((a - 1) as u32, m as u8, t as u32, h));
        walls.insert(
            ((a - 1) as u32, m as u8, t as u32),
            (v3(&r, 3), v3(&r, 6), h),
        );
    }
    Ok(Dumped {
        state: st,
        pairs,
        walls,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dumps_with_wrong_columns_rows_or_step_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.dump");
        let head = "ITEM: TIMESTEP\n7\nITEM: NUMBER OF ENTRIES\n2\nITEM: BOX BOUNDS pp ff pp\n0 1\n0 1\n0 1\n";
        std::fs::write(&p, format!("{head}ITEM: ENTRIES c[1] c[2]\n1 2\n3 4\n")).unwrap();
        assert_eq!(dump_rows(&p, 7, 2).unwrap().len(), 2);
        let e = dump_rows(&p, 7, 3).unwrap_err().to_string();
        assert!(
            e.contains("d.dump") && e.contains("2 columns, expected 3"),
            "{e}"
        );
        let e = dump_rows(&p, 8, 2).unwrap_err().to_string();
        assert!(e.contains("timestep Some(7), expected 8"), "{e}");
        std::fs::write(&p, format!("{head}ITEM: ENTRIES c[1] c[2]\n1 2\n")).unwrap();
        let e = dump_rows(&p, 7, 2).unwrap_err().to_string();
        assert!(e.contains("1 rows, header says 2"), "{e}");
        std::fs::write(&p, format!("{head}ITEM: ENTRIES c[1] c[2]\n1 2\n3 x\n")).unwrap();
        assert!(dump_rows(&p, 7, 2)
            .unwrap_err()
            .to_string()
            .contains("row 2"));
    }
}
