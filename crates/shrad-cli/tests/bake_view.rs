//! `shrad bake` and `shrad view` as a user meets them: a bake reads back as a scene with its
//! light in COLOR_0; bad input exits non-zero naming the problem and leaves no file; the
//! viewer starts, prints its URL and answers on it.

use crate::common;

use std::io::{BufRead, BufReader, Read, Write};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use common::{bake_cornell, files_in, shrad, temp_dir};

#[test]
fn bake_cornell_reads_back_with_colour_per_vertex() {
    let (_, out, o) = bake_cornell("bake", &[]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "stderr: {stderr}");
    assert!(
        stdout.contains(&format!("wrote {}", out.display())),
        "{stdout}"
    );
    let cornell = shrad_scene::cornell_box();
    let back = shrad_scene::load(&out, &Default::default()).unwrap();
    assert_eq!(back.objects.len(), cornell.objects.len());
    for (a, b) in back.objects.iter().zip(&cornell.objects) {
        assert_eq!(a.name, b.name);
        // The loader drops an all-white COLOR_0 (a no-op for a reflector): the light's,
        // saturated at any exposure. Every other object has its light per vertex.
        if a.role != Some(shrad_scene::Role::Light) {
            assert_eq!(a.mesh.colors.len(), a.mesh.positions.len(), "{}", a.name);
        }
        assert!(a.mesh.colors.iter().all(|c| c.is_finite()));
    }
    // Lit: some vertex of the box is neither black nor clamped everywhere.
    let lit = back
        .objects
        .iter()
        .flat_map(|o| &o.mesh.colors)
        .filter(|c| c.max_element() > 0.01)
        .count();
    assert!(lit > 0, "every COLOR_0 is black");
    let info = shrad(&["info", out.to_str().unwrap(), "--patches", "400"]);
    assert!(info.status.success());
    let text = String::from_utf8_lossy(&info.stdout);
    for object in &cornell.objects {
        assert!(
            text.contains(&object.name),
            "{} not in: {text}",
            object.name
        );
    }
}

/// `bake` with `args` exits 1 naming `needle`, without a panic, and `dir` stays empty.
fn bake_fails(dir: &std::path::Path, args: &[&str], needle: &str) {
    let mut all = vec!["bake", "-q", "--patches", "200"];
    all.extend_from_slice(args);
    let o = shrad(&all);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_ne!(o.status.code(), Some(0), "{args:?} succeeded");
    assert!(stderr.contains(needle), "expected '{needle}' in: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(files_in(dir).is_empty(), "left: {:?}", files_in(dir));
}

#[test]
fn bake_bad_input_fails_cleanly_and_writes_nothing() {
    let dir = temp_dir("bad");
    let out = dir.join("c.glb");
    let out = out.to_str().unwrap();
    bake_fails(&dir, &["/nonexistent/scene.glb", "-o", out], "scene.glb");
    let missing = dir.join("no/such/c.glb");
    bake_fails(
        &dir,
        &["cornell", "-o", missing.to_str().unwrap()],
        "does not exist",
    );
    bake_fails(&dir, &["cornell", "-o", out, "--frames", "0"], "--frames");
    bake_fails(
        &dir,
        &["cornell", "-o", out, "--frames", "3"],
        "not animated",
    );
    let png = dir.join("c.png");
    bake_fails(&dir, &["cornell", "-o", png.to_str().unwrap()], ".glb");
    bake_fails(
        &dir,
        &["cornell", "-o", out, "--time", "1", "--frames", "2"],
        "--frames",
    );
    bake_fails(
        &dir,
        &["cornell", "-o", out, "--exposure", "-1"],
        "--exposure",
    );
    // --passes is a sequence's (it was ignored without --frames), at most 1000.
    bake_fails(&dir, &["cornell", "-o", out, "--passes", "3"], "--frames");
    bake_fails(
        &dir,
        &["cornell", "-o", out, "--frames", "2", "--passes", "5000"],
        "--passes",
    );
    // A folder that cannot be written is found before the solve.
    bake_fails(
        &dir,
        &["cornell", "-o", "/proc/x.glb"],
        "cannot write in /proc",
    );
    // The reference (bake's default) has no per-object probes: refused before solving.
    bake_fails(
        &dir,
        &["cornell", "-o", out, "--probes", "corners"],
        "--solver dispersive",
    );
}

/// `bake` of `scene` (200 patches) into `out`, which succeeds.
fn bake_ok(scene: &str, out: &std::path::Path) {
    let o = shrad(&[
        "bake",
        "-q",
        scene,
        "--patches",
        "200",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// What a user's pass found (2026-12-07): the scene read overwritten by its own bake, a
/// folder at the probes' name that failed after the rest was written, a lightmap texel
/// larger than the scene (a black atlas, exit 0); each refused before anything is written.
#[test]
fn bake_refuses_what_would_overwrite_the_scene_or_leave_part_of_its_outputs() {
    let dir = temp_dir("overwrite");
    let scene = dir.join("room.gltf");
    bake_ok("cornell", &scene);
    let before = std::fs::read(&scene).unwrap();
    let o = shrad(&[
        "bake",
        "-q",
        scene.to_str().unwrap(),
        "--patches",
        "200",
        "-o",
        scene.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("the scene file being read"), "{stderr}");
    assert_eq!(
        std::fs::read(&scene).unwrap(),
        before,
        "the scene was overwritten"
    );

    let dir = temp_dir("probes-folder");
    std::fs::create_dir(dir.join("c.probes.json")).unwrap();
    let out = dir.join("c.glb");
    let o = shrad(&[
        "bake",
        "-q",
        "cornell",
        "--patches",
        "200",
        "--solver",
        "dispersive",
        "--probes",
        "corners",
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("c.probes.json would be written, and is a folder"),
        "{stderr}"
    );
    assert!(!out.exists(), "the bake was left without its probes");

    let dir = temp_dir("huge-texel");
    let out = dir.join("c.glb");
    let out = out.to_str().unwrap();
    bake_fails(
        &dir,
        &["cornell", "-o", out, "--lightmap", "--texel-size", "1e30"],
        "larger than the largest chart",
    );
}

/// A `.gltf`'s buffer is named by a URI: a file name with `%`, `#` or a space is
/// percent-encoded, so the bake reads back (written raw, `50%.gltf`'s `50%.bin` did not).
#[test]
fn a_baked_gltfs_buffer_uri_is_percent_encoded() {
    let dir = temp_dir("uri");
    let out = dir.join("50% #1.gltf");
    bake_ok("cornell", &out);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("\"uri\":\"50%25%20%231.bin\""), "{text}");
    assert!(dir.join("50% #1.bin").is_file());
    let o = shrad(&["info", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Ctrl-C during a sequence's bake removes the files it had staged: exit 130, nothing left
/// (the hidden `.c_0000.glb.staged-PID` files stayed).
#[test]
fn an_interrupted_sequence_leaves_no_file() {
    let dir = temp_dir("interrupted");
    let out = dir.join("c.glb");
    let scene = common::repo().join("scenes/moving_box.toml");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_shrad"))
        .args([
            "bake",
            "-q",
            scene.to_str().unwrap(),
            "--patches",
            "2000",
            "--solver",
            "dispersive",
            "--frames",
            "2000",
            "-o",
            out.to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for the first staged file (the solve before it takes a second or so).
    let started = std::time::Instant::now();
    while files_in(&dir).is_empty() {
        assert!(
            started.elapsed().as_secs() < 120,
            "no file staged in 2 minutes"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the bake ended before it was stopped"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let pid = child.id().to_string();
    let kill = std::process::Command::new("kill")
        .args(["-INT", &pid])
        .status();
    assert!(kill.unwrap().success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert!(files_in(&dir).is_empty(), "left: {:?}", files_in(&dir));
}

#[test]
fn bake_probes_corners_writes_them_in_three_js_order_beside_the_file() {
    let (dir, _, o) = bake_cornell("probes", &["--probes", "corners"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(dir.join("c.probes.json")).unwrap();
    // (No JSON parser in this crate's tests: the fields, as text.)
    for needle in [
        "\"format\": \"shrad-probes\"",
        "\"bands\": 3",
        "\"object\": \"short_block\"",
        "\"object\": \"tall_block\"",
        "\"irradiance_coefficients\"",
    ] {
        assert!(text.contains(needle), "{needle} not in {text}");
    }
    assert_eq!(
        text.matches("\"corner\"").count(),
        16,
        "8 probes per interior object"
    );
}

#[test]
fn view_help_and_missing_scene() {
    let o = shrad(&["view", "--help"]);
    assert!(o.status.success());
    let help = String::from_utf8_lossy(&o.stdout);
    for flag in [
        "--port",
        "--host",
        "--solver",
        "--set",
        "--patches",
        "--web",
        "--token",
        "--max-clients",
        "--watch-only",
    ] {
        assert!(help.contains(flag), "{flag} not in: {help}");
    }
    let o = shrad(&["view", "/nonexistent/scene.glb", "--port", "0"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("scene.glb"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn view_reads_the_reference_flags_of_its_error_button() {
    // The reference's settings reach the viewer (its engine's error solve): a bad one is
    // refused before anything is served, naming the flag. (Without the page's folder, a
    // viewer that ignored the flag fails too, on the folder, instead of serving on.)
    let o = shrad(&[
        "view",
        "cornell",
        "-q",
        "--rays-per-patch",
        "0",
        "--port",
        "0",
        "--web",
        "/nonexistent-web",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--rays-per-patch 0"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// Kills the child when dropped, so a failed assertion leaves no server behind.
struct Running(std::process::Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn view_serves_the_page_on_the_printed_url() {
    let child = Command::new(env!("CARGO_BIN_EXE_shrad"))
        .args(["view", "cornell", "--patches", "300", "--port", "0", "-q"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start shrad view");
    let mut running = Running(child);
    let stdout = running.0.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let line = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("shrad view printed no URL within 60 s");
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no URL in: {line}"));
    let addr = url
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .to_string();
    assert!(addr.starts_with("127.0.0.1:"), "{addr}");
    let mut stream = std::net::TcpStream::connect(&addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    write!(
        stream,
        "GET / HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut response = String::new();
    stream.read_to_string(&mut response).unwrap();
    assert!(
        response.starts_with("HTTP/1.1 200"),
        "{}",
        &response[..response.len().min(300)]
    );
    assert!(response.contains("<html") || response.contains("<!DOCTYPE"));
}

/// A short token is refused before anything is said of patching: the refusal was at once,
/// but after "patching and precomputing...", as if it came after the work.
#[test]
fn view_refuses_a_short_token_before_it_patches() {
    let o = shrad(&["view", "cornell", "--token", "short", "--port", "0"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--token: the token must have at least 16 characters")
            && !err.contains("patching"),
        "{err}"
    );
}
