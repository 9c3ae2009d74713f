//! The command line as a user meets it: bad input gives a clear error naming the file, a
//! non-zero exit, no panic and no output file; good input writes what it says.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{repo, shrad, temp_dir};

/// Rendering `scene` fails cleanly: exit code 1, the message names `needle`, no panic, and
/// the output picture does not exist.
fn fails_cleanly(scene: &Path, extra: &[&str], needle: &str) {
    let dir = temp_dir("fail");
    let out = dir.join("out.png");
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-q",
        "-o",
        out.to_str().unwrap(),
    ];
    if !extra.contains(&"--patch-size") {
        args.extend(["--patches", "200"]);
    }
    args.extend_from_slice(extra);
    let o = shrad(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "stderr: {stderr}");
    assert!(stderr.contains(needle), "expected '{needle}' in: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out.exists(), "an output file was left behind");
    let leftovers: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(
        leftovers.is_empty(),
        "files left in the output folder: {leftovers:?}"
    );
}

/// `shrad render cornell -q --patches 200` with `extra`.
fn render_small_cornell(extra: &[&str]) -> Output {
    let mut args = vec!["render", "cornell", "-q", "--patches", "200"];
    args.extend_from_slice(extra);
    shrad(&args)
}

/// Rendering the Cornell box with each case's options fails cleanly, naming its needle.
fn cornell_fails_cleanly(cases: &[(&[&str], &str)]) {
    for &(extra, needle) in cases {
        fails_cleanly(Path::new("cornell"), extra, needle);
    }
}

#[test]
fn missing_file() {
    fails_cleanly(Path::new("/nonexistent/scene.glb"), &[], "scene.glb");
}

#[test]
fn truncated_glb() {
    let dir = temp_dir("glb");
    // Make a valid GLB from the Cornell box, then cut it in half.
    let glb = dir.join("cornell.glb");
    let scene = shrad_scene::cornell_box();
    shrad_scene::write_gltf(&scene, &glb).unwrap();
    let bytes = std::fs::read(&glb).unwrap();
    let cut = dir.join("cut.glb");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    fails_cleanly(&cut, &[], "cut.glb");
}

#[test]
fn index_out_of_range_nan_and_degenerate_obj() {
    let dir = temp_dir("obj");
    let cases = [
        (
            "index.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
            "index.obj",
        ),
        (
            "nan.obj",
            "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
            "nan.obj",
        ),
        (
            "flat.obj",
            "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
            "zero-area",
        ),
    ];
    for (name, text, needle) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        fails_cleanly(&path, &[], needle);
    }
}

/// A small room scene file: a light of radiance `emission` and a box keyed from rest to
/// `far` along x over one second.
fn keyed_room(emission: &str, far: &str) -> String {
    format!(
        "[settings]\npatches = 1500\n\
         [[object]]\nname = \"room\"\nrole = \"boundary\"\nshape = \"box\"\nsize = [10, 10, 10]\n\
         inward = true\nreflectance = [0.7, 0.7, 0.7]\n\
         [[object]]\nname = \"lamp\"\nrole = \"light\"\nshape = \"quad\"\n\
         corners = [[-1, 4.9, -1], [1, 4.9, -1], [1, 4.9, 1], [-1, 4.9, 1]]\n\
         reflectance = [0, 0, 0]\nemission = {emission}\n\
         [[object]]\nname = \"cube\"\nshape = \"box\"\nsize = [1, 1, 1]\nposition = [0, -4, 0]\n\
         [[object.key]]\ntime = 0\ntranslation = [0, 0, 0]\n\
         [[object.key]]\ntime = 1\ntranslation = [{far}, 0, 0]\n"
    )
}

/// Values that are finite but beyond what a solve's 32-bit sums hold: an emission of 1e38
/// (every frame diverged, a black picture, exit 0) and an animation that throws an object to
/// 1e30 (Embree aborted on its rays, exit 134) are errors naming the file and the object,
/// before anything is written; a reasonable file of the same shape plays.
#[test]
fn radiance_and_animation_beyond_what_a_solve_holds_are_errors() {
    let dir = temp_dir("beyond");
    let bright = dir.join("bright.toml");
    std::fs::write(&bright, keyed_room("[1e38, 1e38, 1e38]", "1")).unwrap();
    fails_cleanly(
        &bright,
        &[],
        "'lamp': emitted radiance up to 1.000e38 is beyond",
    );
    let far = dir.join("far.toml");
    std::fs::write(&far, keyed_room("[10, 10, 10]", "1e30")).unwrap();
    let frames = dir.join("far-frames");
    let scene = far.to_str().unwrap();
    let args = [
        "animate",
        scene,
        "-q",
        "--solver",
        "dispersive",
        "--frames",
        "31",
    ];
    let o = shrad(&[&args[..], &["-o", frames.to_str().unwrap()]].concat());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("far.toml") && err.contains("'cube'") && err.contains("1e12"),
        "{err}"
    );
    assert!(!frames.exists(), "nothing written");
    let near = dir.join("near.toml");
    std::fs::write(&near, keyed_room("[10, 10, 10]", "2")).unwrap();
    let frames = dir.join("near-frames");
    let args = [
        "animate",
        near.to_str().unwrap(),
        "-q",
        "--solver",
        "dispersive",
    ];
    let o = shrad(
        &[
            &args[..],
            &["--frames", "3", "-o", frames.to_str().unwrap()],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn unknown_option_values_and_absurd_parameters() {
    cornell_fails_cleanly(&[
        (&["--width", "0"], "--width"),
        (&["--patch-size", "NaN"], "--patch-size"),
        (
            &["--solver", "dispersive", "--set", "bands=12"],
            "--set bands=",
        ),
        (
            &["--solver", "dispersive", "--set", "emitter_res=0"],
            "--set emitter_res=",
        ),
    ]);
    // clap rejects unknown values itself (exit code 2).
    let o = shrad(&["render", "cornell", "--solver", "magic"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("magic"));
    // A number no 32-bit float holds is refused as typed (it became -inf or 0, and the
    // error said "got -inf").
    for (flag, value) in [("--time", "-1e300"), ("--exposure", "1e-50")] {
        let o = shrad(&["render", "cornell", &format!("{flag}={value}")]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(&format!("{value} is beyond what a 32-bit float holds")),
            "{stderr}"
        );
    }
}

/// Every output is checked before anything is solved: a second output that cannot be
/// written, or one at the picture's own path, was found only after the picture was written
/// (half the set left behind, or the EXR silently in place of the PNG); `--frames 0` drew
/// an unlit picture.
#[test]
fn outputs_and_frames_are_checked_before_the_solve() {
    cornell_fails_cleanly(&[
        (&["--hdr", "/nonexistent-dir/x.exr"], "/nonexistent-dir"),
        (
            &["--export-patches", "/nonexistent-dir/p.csv"],
            "/nonexistent-dir",
        ),
        (&["--solver", "dispersive", "--frames", "0"], "--frames"),
    ]);
    let dir = temp_dir("same-output");
    let out = dir.join("same.png");
    let out = out.to_str().unwrap();
    let o = render_small_cornell(&["-o", out, "--hdr", out]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("is also -o's output"), "{stderr}");
    assert!(!Path::new(out).exists());
}

/// The outputs are all or nothing: an EXR that a device refuses, or a CSV whose path is a
/// folder, leaves the picture at `-o` as it was (it was replaced, and the command failed).
#[test]
fn a_refused_second_output_leaves_the_old_picture() {
    let dir = temp_dir("all-or-nothing");
    let png = dir.join("old.png");
    let folder = dir.join("patches.csv");
    std::fs::create_dir_all(&folder).unwrap();
    for (flag, path, says) in [
        ("--hdr", Path::new("/dev/full"), "/dev/full"),
        ("--export-patches", folder.as_path(), "that is a folder"),
    ] {
        std::fs::write(&png, "old").unwrap();
        let o = render_small_cornell(&["-o", png.to_str().unwrap(), flag, path.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{flag}: {stderr}");
        assert!(stderr.contains(says), "{flag}: {stderr}");
        assert_eq!(std::fs::read_to_string(&png).unwrap(), "old", "{flag}");
    }
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        left.len(),
        2,
        "only the old picture and the folder: {left:?}"
    );
}

/// `animate` writes every file or none: a folder where a frame or the statistics go is
/// refused before the solve (the frames before it were left behind, or every frame was
/// solved first), and `--warmup` is bounded (4294967295 ran on, silently).
#[test]
fn animate_refuses_a_taken_name_before_it_solves() {
    let dir = temp_dir("animate-taken");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/moving_box.toml");
    for taken in ["frame_0002.png", "stats.csv"] {
        let out = dir.join(taken.replace('.', "-"));
        std::fs::create_dir_all(out.join(taken)).unwrap();
        let o = shrad(&[
            "animate",
            scene,
            "-q",
            "--patches",
            "300",
            "--frames",
            "4",
            "-o",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{taken}: {stderr}");
        assert!(
            stderr.contains(taken) && stderr.contains("folder"),
            "{stderr}"
        );
        let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
        assert_eq!(left.len(), 1, "{taken}: only the folder");
    }
    let o = shrad(&["animate", scene, "--warmup", "4294967295", "-o", "x"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("0..=1000"));
}

#[test]
fn unwritable_output_leaves_nothing() {
    let o = render_small_cornell(&["-o", "/nonexistent-dir/x.png"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent-dir/x.png"));
}

#[test]
fn scene_without_emitter_warns() {
    let dir = temp_dir("dark");
    let path = dir.join("dark.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let out = dir.join("dark.png");
    let o = shrad(&[
        "render",
        path.to_str().unwrap(),
        "-q",
        "--patches",
        "10",
        "--solver",
        "dispersive",
        "--compare",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no emitter"));
    // A black reference has no relative error: said so, not "NaN %".
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("overall -") && !said.contains("NaN"),
        "{said}"
    );
}

#[test]
fn render_writes_png_exr_and_csv() {
    let dir = temp_dir("ok");
    let (png, exr, csv) = (dir.join("c.png"), dir.join("c.exr"), dir.join("p.csv"));
    let o = shrad(&[
        "render",
        "cornell",
        "-q",
        "--patches",
        "500",
        "--width",
        "32",
        "--height",
        "32",
        "--spp",
        "1",
        "-o",
        png.to_str().unwrap(),
        "--hdr",
        exr.to_str().unwrap(),
        "--export-patches",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(png.exists() && exr.exists());
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("object,role,cx,cy,cz,nx,ny,nz,area,r,g,b")
    );
    let rows: Vec<&str> = lines.collect();
    assert!(rows.len() >= 400);
    assert!(rows.iter().any(|r| r.starts_with("light,light,")));
    // The EXR is linear radiance: the light shows L_e = (17, 12, 4) exactly.
    let image = shrad::image_io::read_exr(&exr).unwrap();
    let brightest = image.pixels.iter().fold(glam::Vec3::ZERO, |a, b| a.max(*b));
    assert!(
        (brightest - glam::Vec3::new(17.0, 12.0, 4.0))
            .abs()
            .max_element()
            < 1e-3,
        "{brightest}"
    );
}

#[test]
fn info_lists_the_punctual_lights_with_both_units_and_where_they_are() {
    let o = shrad(&[
        "info",
        repo().join("scenes/courtyard.toml").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = String::from_utf8_lossy(&o.stdout);
    let line = |name: &str| {
        s.lines()
            .find(|l| l.split_whitespace().nth(1) == Some(name))
            .unwrap_or_else(|| panic!("no line for {name}:\n{s}"))
            .to_string()
    };
    // The number before `unit` on `line`.
    let value = |line: &str, unit: &str| -> f64 {
        let words: Vec<&str> = line.split_whitespace().collect();
        let at = words.iter().position(|w| *w == unit).unwrap();
        words[at - 1].parse().unwrap()
    };
    // The scene file gives the lamp 60 W: 60 / (4 pi) W/sr, 683 lm/W of that in candela.
    let lamp = line("lamp");
    let w = 60.0 / (4.0 * std::f64::consts::PI);
    assert!(
        lamp.contains("point") && lamp.contains("at 0.600 1.600 1.000"),
        "{lamp}"
    );
    assert!((value(&lamp, "W/sr") - w).abs() < 1e-4 * w, "{lamp}");
    assert!(
        (value(&lamp, "cd") - 683.0 * w).abs() < 1e-4 * 683.0 * w,
        "{lamp}"
    );
    let spot = line("spot");
    assert!(
        spot.contains("spot") && spot.contains("cone 15.0..30.0 deg") && spot.contains("towards"),
        "{spot}"
    );
    let sun = line("sun");
    assert!(
        sun.contains("directional") && sun.contains("towards"),
        "{sun}"
    );
    assert!((value(&sun, "W/m^2") - 1.5).abs() < 1e-5, "{sun}");
    assert!((value(&sun, "lx") - 1.5 * 683.0).abs() < 1e-2, "{sun}");
}

#[test]
fn info_prints_roles() {
    let o = shrad(&["info", repo().join("scenes/cornell.obj").to_str().unwrap()]);
    assert!(o.status.success());
    let s = String::from_utf8_lossy(&o.stdout);
    for needle in ["boundary", "interior", "light", "patches"] {
        assert!(s.contains(needle), "{s}");
    }
}

/// `shrad info` checks the file's solver settings as a solve applies them, values too
/// (`cube_res = 0` passed here and failed in `render`), names the sky, and keeps its
/// table's columns (the role column lost its width).
#[test]
fn info_checks_the_settings_values_names_the_sky_and_keeps_its_columns() {
    let dir = temp_dir("info-settings");
    let floor = "[[object]]\nshape = \"quad\"\ncorners = [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]\n";
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        format!("{floor}\n[settings.solver]\nsolver = \"dispersive\"\ncube_res = 0\n"),
    )
    .unwrap();
    let o = shrad(&["info", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("bad.toml: [settings.solver] cube_res = 0"),
        "{err}"
    );
    let sky = dir.join("sky.toml");
    std::fs::write(
        &sky,
        format!("{floor}\n[environment]\nradiance = [0.5, 0.6, 0.8]\n"),
    )
    .unwrap();
    let o = shrad(&["info", sky.to_str().unwrap(), "--env-scale", "2"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("sky: uniform, radiance 1.0000 1.2000 1.6000"),
        "{out}"
    );
    // Every object row's triangle count ends where its header does.
    let o = shrad(&["info", "cornell", "--patches", "500"]);
    let out = String::from_utf8_lossy(&o.stdout);
    let header = out.lines().find(|l| l.contains("triangles")).unwrap();
    let end = header.find("triangles").unwrap() + "triangles".len();
    let rows: Vec<&str> = out
        .lines()
        .skip_while(|l| !l.contains("triangles"))
        .skip(1)
        .collect();
    assert!(rows.len() >= 8, "{out}");
    for row in rows {
        let before = &row[..end];
        assert!(
            before.ends_with(|c: char| c.is_ascii_digit()) && row[end..].starts_with(' '),
            "a column moved:\n{header}\n{row}"
        );
    }
}

/// A reader that closes the pipe at once (`shrad info cornell | head -1`) ends the report,
/// not the command: no panic, exit 0. A standard output that cannot be written (a full
/// disk) is said and the command exits 1.
#[test]
fn a_closed_or_full_standard_output_is_no_panic() {
    use std::process::{Command, Stdio};
    let scene = repo().join("scenes/cornell.obj");
    for args in [vec!["info", scene.to_str().unwrap()], vec!["options"]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_shrad"))
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            o.status.success() && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
    if let Ok(full) = full {
        let o = Command::new(env!("CARGO_BIN_EXE_shrad"))
            .args(["info", scene.to_str().unwrap()])
            .stdout(full)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("cannot print to standard output") && !err.contains("panicked"));
    }
}

#[test]
fn animate_writes_frames_gif_and_stats() {
    let dir = temp_dir("anim");
    let scene = repo().join("scenes/moving_box.toml");
    let o = shrad(&[
        "animate",
        scene.to_str().unwrap(),
        "-q",
        "--patches",
        "600",
        "--frames",
        "4",
        "--width",
        "24",
        "--height",
        "24",
        "--solver",
        "dispersive",
        "--set",
        "cube_res=8",
        "--error-every",
        "2",
        "--rays-per-patch",
        "16",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stats = std::fs::read_to_string(dir.join("stats.csv")).unwrap();
    let mut lines = stats.lines();
    assert_eq!(
        lines.next(),
        Some(
            "frame,objects_updated,direct_ms,objects_ms,to_boundary_ms,assemble_ms,frame_ms,error"
        )
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 4);
    assert!(!rows[0][7].is_empty() && rows[1][7].is_empty() && !rows[2][7].is_empty());
    assert!(dir.join("frame_0003.png").exists() && dir.join("animation.gif").exists());
}

/// `scenes/moving_box.toml` at 600 patches with `solver` as its `[settings.solver]`.
fn scene_with_settings(dir: &Path, name: &str, solver: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("scenes/moving_box.toml")).unwrap();
    assert!(text.contains("patch_size = 20.0\n"));
    let text = text.replace(
        "patch_size = 20.0\n",
        &format!("patches = 600\n\n[settings.solver]\n{solver}\n"),
    );
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The dispersive solver, small, by `--set`: what `scene_with_settings` files are compared to.
const SMALL_DISPERSIVE: [&str; 6] = [
    "--solver",
    "dispersive",
    "--set",
    "cube_res=8",
    "--set",
    "bands=2",
];

/// Render `scene` small and quietly; the patch CSV (radiosity of every patch), or the
/// failed run's output.
fn patch_csv(scene: &Path, extra: &[&str]) -> Result<String, Output> {
    let dir = scene.parent().unwrap();
    let stem = scene.file_stem().unwrap().to_string_lossy();
    let csv = dir.join(format!("{stem}-{}.csv", extra.join("_")));
    let png = dir.join(format!("{stem}.png"));
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-q",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "-o",
        png.to_str().unwrap(),
        "--export-patches",
        csv.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = shrad(&args);
    if !o.status.success() {
        return Err(o);
    }
    Ok(std::fs::read_to_string(&csv).unwrap())
}

#[test]
fn scene_file_solver_settings_apply_and_the_command_line_wins() {
    let dir = temp_dir("settings");
    // Kebab and snake case both work.
    let file = scene_with_settings(
        &dir,
        "file.toml",
        "solver = \"dispersive\"\ncube_res = 8\nbands = 2\nper-frame = 1",
    );
    let plain = scene_with_settings(&dir, "plain.toml", "");
    let from_file = patch_csv(&file, &[]).unwrap();
    let from_flags = patch_csv(&plain, &SMALL_DISPERSIVE).unwrap();
    assert_eq!(from_file, from_flags, "the file's settings are not applied");
    let other_bands =
        patch_csv(&plain, &["--solver", "dispersive", "--set", "cube_res=8"]).unwrap();
    assert_ne!(from_file, other_bands, "--bands does not change the result");
    // A value the file gets wrong is overridden by the command line, so never checked.
    let bad = scene_with_settings(
        &dir,
        "bad.toml",
        "solver = \"dispersive\"\ncube-res = 8\nbands = 9",
    );
    assert_eq!(patch_csv(&bad, &["--set", "bands=2"]).unwrap(), from_file);
}

#[test]
fn scene_file_solver_settings_errors_name_the_file_and_key() {
    let dir = temp_dir("settings-bad");
    let cases = [
        (
            "cube-rez = 8",
            "[settings.solver] cube-rez: unknown setting (did you mean cube_res?)",
        ),
        ("wibble = 1", "[settings.solver] wibble: unknown setting"),
        (
            "solver = \"dispersive\"\ncube-res = \"big\"",
            "[settings.solver] cube-res = big: dispersive option cube_res = big: must be integer 1..=2048",
        ),
        (
            "solver = \"magic\"",
            "[settings.solver] solver = magic: invalid value",
        ),
        (
            "solver = \"dispersive\"\nbands = 9",
            "[settings.solver] bands = 9: dispersive option bands = 9: must be integer 1..=8",
        ),
        (
            "solver = \"dispersive\"\npreset = \"fastest\"",
            "[settings.solver] preset: the dispersive solver has no preset 'fastest' (presets: default, paper)",
        ),
        (
            "cube-res = [8, 8]",
            "[settings.solver] cube-res: must be a string",
        ),
    ];
    for (i, (settings, needle)) in cases.into_iter().enumerate() {
        let name = format!("case{i}.toml");
        let scene = scene_with_settings(&dir, &name, settings);
        let o = patch_csv(&scene, &[]).expect_err(settings);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{settings}: {stderr}");
        assert!(
            stderr.contains(&name),
            "{settings}: no file name in {stderr}"
        );
        assert!(
            stderr.contains(needle),
            "{settings}: expected '{needle}' in {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    // `info` checks the keys too.
    let scene = dir.join("case0.toml");
    let o = shrad(&["info", scene.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cube-rez"));
}

/// A successful run with `--quiet` writes nothing to stderr: no bars, no informational
/// lines.
fn quiet_run(args: &[&str]) {
    let o = shrad(args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{args:?}: {stderr}");
    assert!(stderr.is_empty(), "{args:?} printed: {stderr}");
}

#[test]
fn quiet_is_quiet_on_every_command() {
    let dir = temp_dir("quiet");
    let png = dir.join("c.png");
    let small = ["--width", "16", "--height", "16", "--spp", "1"];
    let mut render = vec!["render", "cornell", "--quiet", "--patches", "300"];
    render.extend(small);
    render.extend(["-o", png.to_str().unwrap()]);
    quiet_run(&render);
    let mut dispersive = render.clone();
    dispersive.extend(["--solver", "dispersive", "--set", "cube_res=8", "--compare"]);
    quiet_run(&dispersive);
    quiet_run(&["info", "cornell", "-q", "--patches", "300"]);
    let moving = repo().join("scenes/moving_box.toml");
    let anim = dir.join("anim");
    let mut animate = vec![
        "animate",
        moving.to_str().unwrap(),
        "-q",
        "--patches",
        "300",
        "--frames",
        "2",
        "--solver",
        "dispersive",
        "--set",
        "cube_res=8",
        "-o",
        anim.to_str().unwrap(),
    ];
    animate.extend(small);
    quiet_run(&animate);
    let bench = dir.join("bench");
    quiet_run(&[
        "bench",
        "--quiet",
        "--quick",
        "--solvers",
        "dispersive",
        "--patches",
        "800",
        "--rays-per-patch",
        "8",
        "--out",
        bench.to_str().unwrap(),
    ]);
    assert!(bench.join("results.json").exists());
    // Without --quiet a solve says which visibility backend it uses.
    let loud: Vec<&str> = render.iter().copied().filter(|a| *a != "--quiet").collect();
    let o = shrad(&loud);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("visibility: "));
}

#[test]
fn option_values_that_would_abort_are_errors() {
    cornell_fails_cleanly(&[
        (&["--patch-size", "-5"], "--patch-size"),
        (&["--patch-size", "0"], "--patch-size"),
        (&["--patch-size", "1e-7"], "--patch-size"),
        (
            &["--solver", "dispersive", "--set", "cube_res=0"],
            "--set cube_res=",
        ),
        (
            &["--solver", "grid", "--set", "cube_res=0"],
            "--set cube_res=",
        ),
        (&["--solver", "grid", "--set", "bands=9"], "--set bands="),
        (&["--exposure", "-1"], "--exposure"),
        (
            &["--width", "16384", "--height", "16384", "--spp", "4096"],
            "--width",
        ),
    ]);
    let o = shrad(&["info", "cornell", "--patch-size", "1e-7"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--patch-size"));
}

/// The Blender-exported animated room (validation/blender_animation.py).
fn blender_room() -> PathBuf {
    repo().join("crates/shrad-scene/tests/data/blender/animated_room.glb")
}

/// Area-weighted centre of object `name`'s patches in a `--export-patches` CSV.
fn patch_centre(csv: &Path, name: &str) -> [f64; 3] {
    let text = std::fs::read_to_string(csv).unwrap();
    let (mut sum, mut area) = ([0.0; 3], 0.0);
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f[0] != name {
            continue;
        }
        let a: f64 = f[8].parse().unwrap();
        for k in 0..3 {
            sum[k] += a * f[2 + k].parse::<f64>().unwrap();
        }
        area += a;
    }
    assert!(area > 0.0, "no patches of {name} in {}", csv.display());
    sum.map(|s| s / area)
}

#[test]
fn render_time_poses_the_gltf_animation() {
    let dir = temp_dir("render-time");
    let room = blender_room();
    let mut centres = Vec::new();
    for t in ["0", "0.958333", "1.958333"] {
        let csv = dir.join(format!("patches_{t}.csv"));
        let o = shrad(&[
            "render",
            room.to_str().unwrap(),
            "-q",
            "--patches",
            "400",
            "--frames",
            "1",
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "1",
            "--time",
            t,
            "--export-patches",
            csv.to_str().unwrap(),
            "-o",
            dir.join("out.png").to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        centres.push(patch_centre(&csv, "mover"));
    }
    // Blender's mover (a cube centred on its origin) at frames 1, 24 and 48, in glTF axes
    // (x, z, -y): location keys (-1.2, -1, 0.25), (0, 0.6, 0.25), (1.1, 1.2, 0.6).
    let want = [[-1.2, 0.25, 1.0], [0.0, 0.25, -0.6], [1.1, 0.6, -1.2]];
    for (c, w) in centres.iter().zip(want) {
        let d = (0..3).map(|k| (c[k] - w[k]).powi(2)).sum::<f64>().sqrt();
        assert!(d < 1e-3, "mover centre {c:?}, Blender has {w:?}");
    }
}

#[test]
fn info_lists_gltf_animations_and_animate_plays_all_of_it() {
    let room = blender_room();
    let o = shrad(&["info", room.to_str().unwrap(), "--patches", "300"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.contains("glTF animations: 2 (2 playing"), "{out}");
    assert!(
        out.contains("moverAction") && out.contains("pulserAction"),
        "{out}"
    );
    assert!(out.contains("0.000 .. 1.958 s"), "{out}");
    let o = shrad(&[
        "info",
        room.to_str().unwrap(),
        "--animation",
        "pulserAction",
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("(1 playing") && out.contains("(not playing)"),
        "{out}"
    );
    let o = shrad(&["info", room.to_str().unwrap(), "--animation", "walk"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("animated_room.glb")
            && err.contains("'walk'")
            && err.contains("0 'moverAction'"),
        "{err}"
    );
    // No --frames: the whole 1.958 s at 4 fps is frames 0..=8 (t = 0 .. 2.0, the last pose
    // held); --hdr writes an EXR beside each PNG.
    let dir = temp_dir("animate-gltf");
    let o = shrad(&[
        "animate",
        room.to_str().unwrap(),
        "-q",
        "--patches",
        "300",
        "--fps",
        "4",
        "--warmup",
        "0",
        "--width",
        "8",
        "--height",
        "8",
        "--hdr",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stats = std::fs::read_to_string(dir.join("stats.csv")).unwrap();
    assert_eq!(stats.lines().count(), 1 + 9, "{stats}");
    assert!(dir.join("frame_0008.png").exists() && dir.join("frame_0008.exr").exists());
    assert!(!dir.join("frame_0009.png").exists());
}

#[test]
fn set_applies_keys_and_the_preset_and_old_flags_name_their_key() {
    let dir = temp_dir("set");
    let plain = scene_with_settings(&dir, "plain.toml", "");
    let by_set = patch_csv(&plain, &SMALL_DISPERSIVE).unwrap();
    // A flag of before `--set` is an error that names the key to set.
    let old = patch_csv(&plain, &["--solver", "dispersive", "--cube-res", "8"]).unwrap_err();
    let stderr = String::from_utf8_lossy(&old.stderr);
    assert!(!old.status.success(), "{stderr}");
    assert!(
        stderr.contains("--cube-res is no longer a flag: use --set cube_res=8"),
        "{stderr}"
    );
    // `-` stands for `_`, and the schedule is set before its parameters whatever the order.
    let scheduled = patch_csv(
        &plain,
        &[
            "--solver",
            "dispersive",
            "--set",
            "cube-res=8",
            "--set",
            "per_frame=2",
            "--set",
            "schedule=round_robin",
        ],
    )
    .unwrap();
    assert_ne!(scheduled, by_set);
    let paper = patch_csv(
        &plain,
        &[
            "--solver",
            "dispersive",
            "--preset",
            "paper",
            "--set",
            "cube_res=8",
        ],
    )
    .unwrap();
    assert_ne!(paper, by_set, "--preset paper changes nothing");
}

#[test]
fn set_errors_name_the_key() {
    let dispersive = [
        // An unknown key lists the solver's keys.
        (
            "wibble=1",
            "--set wibble=1: the dispersive solver has no option 'wibble' (options: bands, cube_res",
        ),
        // Out of range: the key and its range, whatever the spelling.
        (
            "cube_res=0",
            "--set cube_res=0: dispersive option cube_res = 0: must be integer 1..=2048",
        ),
        (
            "probe-margin=2",
            "--set probe-margin=2: dispersive option probe_margin = 2: must be number 0..=1",
        ),
        (
            "schedule=sometimes",
            "--set schedule=sometimes: dispersive option schedule = sometimes: must be round_robin|priority|budget|full",
        ),
        ("bands", "--set bands: expected KEY=VALUE"),
    ];
    for (set, needle) in dispersive {
        let cornell = Path::new("cornell");
        fails_cleanly(cornell, &["--solver", "dispersive", "--set", set], needle);
    }
    cornell_fails_cleanly(&[
        // A key of another solver is an error on the command line, not silently ignored.
        (
            &["--solver", "grid", "--set", "schedule=full"],
            "--set schedule=full: the grid solver has no option 'schedule'",
        ),
        (
            &["--solver", "grid", "--preset", "paper"],
            "the grid solver has no preset 'paper' (presets: paper5, paper4)",
        ),
    ]);
}

/// Every key of `solver` in the library, by `shrad options SOLVER`'s own source.
fn library_keys(solver: &str) -> Vec<&'static str> {
    shrad::solver::SolverChoice::keys_of(solver)
        .unwrap()
        .iter()
        .map(|k| k.name)
        .collect()
}

#[test]
fn options_lists_every_key_with_its_default_and_range() {
    let o = shrad(&["options"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    for solver in shrad::settings::SOLVERS {
        assert!(out.contains(&format!("## {solver}")), "{out}");
        for key in library_keys(solver) {
            assert!(
                out.contains(&format!("| `{key}` |")),
                "{key} missing: {out}"
            );
        }
    }
    // The default and paper presets side by side, with the range.
    assert!(
        out.contains("| `cube_res` | 32 | 128 | integer 1..=2048 | yes |"),
        "{out}"
    );
    let o = shrad(&["options", "grid"]);
    let grid = String::from_utf8_lossy(&o.stdout);
    assert!(grid.contains("| `per_axis` | 5 | 4 |"), "{grid}");
    assert!(!grid.contains("`schedule`"), "{grid}");
    let o = shrad(&["options", "magic"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn docs_options_md_is_the_output_of_shrad_options() {
    let o = shrad(&["options"]);
    assert!(o.status.success());
    let doc = std::fs::read_to_string(repo().join("docs/options.md")).unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        doc == out,
        "docs/options.md is out of date: regenerate it with the command written in it"
    );
}

/// `render x.obj -o x.obj` wrote its PNG over the scene (exit 0, with a warning about the
/// extension); now refused before the solve, the scene as it was.
#[test]
fn render_refuses_to_write_over_the_scene_it_reads() {
    let dir = temp_dir("render-over-scene");
    let scene = dir.join("x.obj");
    std::fs::copy(repo().join("scenes/cornell.obj"), &scene).unwrap();
    std::fs::copy(repo().join("scenes/cornell.mtl"), dir.join("cornell.mtl")).unwrap();
    let before = std::fs::read(&scene).unwrap();
    for flag in ["-o", "--hdr", "--export-patches"] {
        let o = shrad(&[
            "render",
            "-q",
            scene.to_str().unwrap(),
            "--patches",
            "200",
            flag,
            scene.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{flag}: {stderr}");
        assert!(
            stderr.contains("the scene file being read"),
            "{flag}: {stderr}"
        );
        assert_eq!(
            std::fs::read(&scene).unwrap(),
            before,
            "{flag}: the scene was overwritten"
        );
    }
}

/// Without `--frames` the grid renders its light settled: in a closed box whose walls emit
/// M = 1 and reflect 0.9, B = M / (1 - 0.9) = 10 everywhere; at its fixed 8 frames (8
/// bounces) the grid had 1 + 0.9 + ... + 0.9^8 = 6.1.
#[test]
fn a_grid_render_settles_in_a_bright_furnace() {
    let dir = temp_dir("grid-furnace");
    let scene = dir.join("furnace.toml");
    std::fs::write(
        &scene,
        "[[object]]\nname = \"room\"\nrole = \"boundary\"\nshape = \"box\"\nsize = [1, 1, 1]\ninward = true\nreflectance = [0.9, 0.9, 0.9]\nemission = [0.3183099, 0.3183099, 0.3183099]\n",
    )
    .unwrap();
    let csv = dir.join("patches.csv");
    let o = shrad(&[
        "render",
        scene.to_str().unwrap(),
        "--solver",
        "grid",
        "--patches",
        "600",
        "--width",
        "16",
        "--height",
        "16",
        "--export-patches",
        csv.to_str().unwrap(),
        "-o",
        dir.join("f.png").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&csv).unwrap();
    let (mut area, mut power) = (0.0f64, 0.0f64);
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line
            .split(',')
            .skip(2)
            .map(|x| x.parse().unwrap())
            .collect();
        area += f[6];
        power += f[6] * f[7];
    }
    let mean = power / area;
    assert!((mean - 10.0).abs() < 0.1, "mean B {mean}, closed form 10");
}
