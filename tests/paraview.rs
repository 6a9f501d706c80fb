//! ParaView output read back with VTK itself (Debian's python3-vtk9, run by /usr/bin/python3):
//! a short ci shear in both codes writes particle and plate snapshots; every file the `.pvd`
//! collections name must load, hold every particle with its id, radius, velocity and angular
//! velocity (native also the accumulated rotation), both plates, and the physical time of its
//! step.

mod common;

use common::text;

const READER: &str = r#"
import json, sys
import xml.etree.ElementTree as ET
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader
from vtkmodules.util.numpy_support import vtk_to_numpy
out = {}
for code in ("native", "liggghts"):
    d = sys.argv[1]
    sets = []
    for ds in ET.parse(f"{d}/{code}.pvd").getroot().iter("DataSet"):
        r = vtkXMLUnstructuredGridReader()
        r.SetFileName(f"{d}/{ds.get('file')}")
        r.Update()
        g = r.GetOutput()
        pd, cd = g.GetPointData(), g.GetCellData()
        arrays = {pd.GetArrayName(k): pd.GetArray(k).GetNumberOfComponents() for k in range(pd.GetNumberOfArrays())}
        cells = {cd.GetArrayName(k): sorted(set(vtk_to_numpy(cd.GetArray(k)).tolist())) for k in range(cd.GetNumberOfArrays())}
        ids = sorted(vtk_to_numpy(pd.GetArray("id")).tolist()) if "id" in arrays else []
        radius = vtk_to_numpy(pd.GetArray("radius")).tolist() if "radius" in arrays else []
        ys = vtk_to_numpy(g.GetPoints().GetData())[:, 1].tolist() if g.GetNumberOfPoints() else []
        sets.append({
            "timestep": float(ds.get("timestep")),
            "part": int(ds.get("part")),
            "time_value": g.GetFieldData().GetArray("TimeValue").GetValue(0),
            "points": g.GetNumberOfPoints(),
            "cells": g.GetNumberOfCells(),
            "arrays": arrays,
            "cell_arrays": cells,
            "ids_are_1_to_n": ids == list(range(1, len(ids) + 1)),
            "radius_range": [min(radius), max(radius)] if radius else [],
            "y_range": [min(ys), max(ys)] if ys else [],
        })
    out[code] = sets
print(json.dumps(out))
"#;

#[test]
fn snapshots_load_in_vtk_with_their_fields_count_and_time() {
    common::liggghts();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = common::short_ci_shear(&out, &["--snapshot-every", "4000", "--mu-margin", "0.5"]);
    let t = text(&o);
    // any verdict: this test reads the snapshots
    assert!(
        matches!(o.status.code(), Some(0) | Some(1) | Some(3)),
        "{t}"
    );
    assert!(
        t.contains("particle snapshots for ParaView every 4000 steps (6.000e-3 s)"),
        "{t}"
    );
    let vtk = out.join("seed1/vtk");
    let py = std::process::Command::new("/usr/bin/python3")
        .args(["-c", READER, vtk.to_str().unwrap()])
        .output()
        .expect("Debian's python3 (with python3-vtk9: tools/setup.sh installs it)");
    assert!(py.status.success(), "{}", text(&py));
    let v: serde_json::Value = serde_json::from_slice(&py.stdout).unwrap();
    let dt = 1.5e-6;
    // the initial state, then compression 12,000 steps and about 5,000 of shear: snapshots
    // at 0, 4,000 .. 16,000
    let steps = [0u64, 4000, 8000, 12000, 16000];
    for code in ["native", "liggghts"] {
        let sets = v[code].as_array().unwrap();
        assert_eq!(
            sets.len(),
            2 * steps.len(),
            "{code}: particles and plates per step"
        );
        for (k, step) in steps.iter().enumerate() {
            let time = *step as f64 * dt;
            for s in &sets[2 * k..2 * k + 2] {
                let ts = s["timestep"].as_f64().unwrap();
                assert!((ts - time).abs() <= 1e-12 * time, "{code} {s}");
                assert_eq!(s["time_value"].as_f64().unwrap(), ts, "{code} {s}");
            }
            let p = &sets[2 * k];
            assert_eq!(p["part"], 0);
            assert_eq!(p["points"], 300, "{code} {p}");
            assert_eq!(p["cells"], 300, "{code} {p}");
            assert_eq!(p["ids_are_1_to_n"], true, "{code} {p}");
            for (name, comps) in [("radius", 1), ("velocity", 3), ("omega", 3)] {
                assert_eq!(p["arrays"][name], comps, "{code} {name}: {p}");
            }
            if code == "native" {
                assert_eq!(p["arrays"]["rotation"], 3, "{p}");
                assert_eq!(p["arrays"]["rotation_magnitude"], 1, "{p}");
            }
            let r = p["radius_range"].as_array().unwrap();
            assert_eq!(
                (r[0].as_f64().unwrap(), r[1].as_f64().unwrap()),
                (1e-4, 2e-4)
            );
            let plates = &sets[2 * k + 1];
            assert_eq!(plates["part"], 1);
            assert_eq!(
                plates["cell_arrays"]["plate"],
                serde_json::json!([0, 1]),
                "{plates}"
            );
            // the particles lie between the plates
            let (py, ppl) = (&p["y_range"], &plates["y_range"]);
            assert!(
                py[0].as_f64().unwrap() > ppl[0].as_f64().unwrap()
                    && py[1].as_f64().unwrap() < ppl[1].as_f64().unwrap(),
                "{code}: particles {py} plates {ppl}"
            );
        }
    }
}

/// `verify profile` on a native ci run with snapshots in its steady window: the profile from
/// grain displacements is written, the toothed plates grip (slip well under the plate speed)
/// and the gouge shears (the bottom layer faster than the top one), with the stage's rotation
/// map; a snapshot cut short is an error naming it, not a profile.
#[test]
fn displacement_profile_from_the_snapshots_of_a_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = common::short_ci_shear(&out, &["--native-only", "--snapshot-every", "250"]);
    assert!(
        matches!(o.status.code(), Some(0) | Some(1) | Some(3)),
        "{}",
        text(&o)
    );
    let seed = out.join("seed1");
    let o = common::verify(&["profile", seed.to_str().unwrap()]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let profiles: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(seed.join("native_displacement_profile.json")).unwrap(),
    )
    .unwrap();
    let p = &profiles[0];
    let layers = p["layers"].as_array().unwrap();
    let u = |k: usize| layers[k]["u"].as_f64().unwrap();
    assert!(p["samples"].as_u64().unwrap() >= 5, "{p}");
    assert!(u(0) > u(layers.len() - 1) + 0.3, "the gouge shears: {p}");
    for side in ["slip_bottom", "slip_top"] {
        let s = p[side].as_f64().unwrap();
        assert!(s.abs() < 0.3, "{side} {s}: the teeth grip ({p})");
    }
    assert!(seed.join("displacement_profile.svg").is_file());
    assert!(t.contains("slip bottom") && t.contains("band width"), "{t}");
    // and the stage's rotation map: one disc and its outline a grain, over the window
    let map = std::fs::read_to_string(seed.join("rotation_map_stage1.svg")).unwrap();
    let case: toml::Value =
        toml::from_str(&std::fs::read_to_string(seed.join("case.toml")).unwrap()).unwrap();
    let n = case["particles"].as_integer().unwrap() as usize;
    assert_eq!(map.matches("<circle").count(), 2 * n);
    assert!(
        map.contains("stage 1")
            && map.contains("rotation over steps")
            && map.contains("99 % under")
    );
    assert!(t.contains("1 stage rotation map(s)"), "{t}");
    // a stage with no snapshots in its steady window (as a run resumed on another machine
    // from a carried checkpoint has for the stages before it): no profile for it, said, and
    // the others' still made
    let case_path = seed.join("case.toml");
    let case = std::fs::read_to_string(&case_path).unwrap();
    let speed = case
        .split("[[stages]]")
        .nth(1)
        .and_then(|st| st.lines().find_map(|l| l.strip_prefix("speed = ")))
        .unwrap()
        .trim()
        .to_string();
    std::fs::write(
        &case_path,
        format!("{case}\n[[stages]]\nspeed = {speed}\nstrain = 0.05\n"),
    )
    .unwrap();
    let o = common::verify(&["profile", seed.to_str().unwrap()]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("stage 2") && t.contains("0 snapshot(s) in its steady window"),
        "{t}"
    );
    let two: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(seed.join("native_displacement_profile.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        two, profiles,
        "the first stage's profile as before, none for the second"
    );
    std::fs::write(&case_path, &case).unwrap();
    // a snapshot cut short
    let vtk = seed.join("vtk");
    let victim = std::fs::read_dir(&vtk)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy().into_owned();
            n.starts_with("native_0") && n.ends_with(".vtu")
        })
        .max()
        .unwrap();
    let bytes = std::fs::read(&victim).unwrap();
    std::fs::write(&victim, &bytes[..bytes.len() / 2]).unwrap();
    let o = common::verify(&["profile", seed.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains(victim.file_name().unwrap().to_str().unwrap()) && t.contains("cut short"),
        "{t}"
    );
    // no stage with snapshots enough: an error, nothing written
    std::fs::remove_dir_all(&vtk).unwrap();
    std::fs::create_dir(&vtk).unwrap();
    let o = common::verify(&["profile", seed.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("3 or more in a stage's steady window"), "{t}");
}
