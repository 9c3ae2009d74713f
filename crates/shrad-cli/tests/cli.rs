//! The command line as a user meets it: bad input gives a clear error naming the file, a
//! non-zero exit, no panic and no output file; good input writes what it says.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn shrad(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shrad"))
        .args(args)
        .output()
        .expect("run shrad")
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shrad-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

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

#[test]
fn unknown_option_values_and_absurd_parameters() {
    let cornell = Path::new("cornell");
    fails_cleanly(cornell, &["--width", "0"], "--width");
    fails_cleanly(cornell, &["--patch-size", "NaN"], "--patch-size");
    fails_cleanly(
        cornell,
        &["--solver", "dispersive", "--bands", "12"],
        "--bands",
    );
    fails_cleanly(
        cornell,
        &["--solver", "dispersive", "--emitter-res", "0"],
        "--emitter-res",
    );
    // clap rejects unknown values itself (exit code 2).
    let o = shrad(&["render", "cornell", "--solver", "magic"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("magic"));
}

#[test]
fn unwritable_output_leaves_nothing() {
    let o = shrad(&[
        "render",
        "cornell",
        "-q",
        "--patches",
        "200",
        "-o",
        "/nonexistent-dir/x.png",
    ]);
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
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no emitter"));
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
fn info_prints_roles() {
    let o = shrad(&["info", repo().join("scenes/cornell.obj").to_str().unwrap()]);
    assert!(o.status.success());
    let s = String::from_utf8_lossy(&o.stdout);
    for needle in ["boundary", "interior", "light", "patches"] {
        assert!(s.contains(needle), "{s}");
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
        "--cube-res",
        "8",
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
