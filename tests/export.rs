//! `fluid-lab export` and `fluid-lab render` on the real binary: VTK and CSV files parsed
//! back and compared with the reference outputs, rendered PNG series and GIF animations,
//! and no progress bar when stderr is not a terminal.

mod common;

use common::{entries, exit_code, input, reference_output, run_lab, stderr, stdout};
use fluid::io::fld;
use std::collections::HashMap;
use std::path::Path;

/// A legacy VTK polydata file read back: its points and its point-data arrays.
struct Vtk {
    points: Vec<[f64; 3]>,
    arrays: HashMap<String, Vec<f64>>,
}

/// Parses the ASCII legacy VTK that `fluid-lab export` writes, checking its structure.
fn parse_vtk(text: &str) -> Vtk {
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("# vtk DataFile Version 3.0"));
    lines.next().expect("a title line");
    assert_eq!(lines.next(), Some("ASCII"));
    assert_eq!(lines.next(), Some("DATASET POLYDATA"));
    let header: Vec<&str> = lines.next().unwrap().split(' ').collect();
    assert_eq!((header[0], header[2]), ("POINTS", "float"));
    let n: usize = header[1].parse().unwrap();
    // Floats as written (f32, the precision of .fld files), doubles and ints as f64.
    let numbers = |line: &str, float: bool| -> Vec<f64> {
        line.split(' ')
            .map(|v| match float {
                true => v.parse::<f32>().unwrap() as f64,
                false => v.parse().unwrap(),
            })
            .collect()
    };
    let points: Vec<[f64; 3]> = (0..n)
        .map(|_| numbers(lines.next().unwrap(), true).try_into().unwrap())
        .collect();
    assert_eq!(
        lines.next(),
        Some(format!("VERTICES {n} {}", 2 * n).as_str())
    );
    for i in 0..n {
        assert_eq!(lines.next(), Some(format!("1 {i}").as_str()));
    }
    assert_eq!(lines.next(), Some(format!("POINT_DATA {n}").as_str()));
    let mut arrays = HashMap::new();
    while let Some(line) = lines.next() {
        let words: Vec<&str> = line.split(' ').collect();
        let (name, width) = match words[0] {
            "VECTORS" => (words[1], 3),
            "SCALARS" => {
                assert_eq!(lines.next(), Some("LOOKUP_TABLE default"));
                (words[1], 1)
            }
            other => panic!("unexpected section {other}"),
        };
        let float = words[2] == "float";
        let values: Vec<f64> = (0..n)
            .flat_map(|_| numbers(lines.next().unwrap(), float))
            .collect();
        assert_eq!(values.len(), n * width, "{name}");
        arrays.insert(name.to_string(), values);
    }
    Vtk { points, arrays }
}

fn export(args: &[&str]) -> std::process::Output {
    let output = run_lab(args);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    // Not a terminal: no progress bar, nothing on stderr.
    assert_eq!(stderr(&output), "");
    output
}

#[test]
fn vtk_exports_of_a_run_match_the_input_and_the_reference_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let small = input("small");
    let output = export(&[
        "export",
        small.to_str().unwrap(),
        out,
        "--steps",
        "2",
        "--every",
        "1",
    ]);
    let names: Vec<String> = (0..=2).map(|step| format!("small_{step:06}.vtk")).collect();
    let expected: String = names
        .iter()
        .chain([&"small-frames.csv".to_string()])
        .map(|name| format!("wrote {out}/{name}\n"))
        .collect();
    assert_eq!(stdout(&output), expected);
    // The index of the frames: each one's step, physical time (1 ms steps) and file.
    assert_eq!(
        std::fs::read_to_string(dir.path().join("small-frames.csv")).unwrap(),
        "step,time_s,file\n0,0,small_000000.vtk\n1,0.001,small_000001.vtk\n2,0.002,small_000002.vtk\n"
    );

    for (step, name) in names.iter().enumerate().take(2) {
        let vtk = parse_vtk(&std::fs::read_to_string(dir.path().join(name)).unwrap());
        let truth = match step {
            0 => std::fs::read(&small).unwrap(),
            _ => std::fs::read(reference_output("small", step as u32)).unwrap(),
        };
        let truth = fld::parse(&truth, name).unwrap().particles;
        assert_eq!(vtk.points.len(), 4800);
        for i in 0..4800 {
            for axis in 0..3 {
                assert_eq!(vtk.points[i][axis], truth.p[axis][i], "{name} particle {i}");
                assert_eq!(vtk.arrays["velocity"][3 * i + axis], truth.v[axis][i]);
                assert_eq!(vtk.arrays["half_velocity"][3 * i + axis], truth.hv[axis][i]);
            }
        }
        let ids: Vec<f64> = (0..4800).map(f64::from).collect();
        assert_eq!(vtk.arrays["id"], ids);
        // Densities near the rest density (1000) in the bulk; blocks within the grid
        // (small.fld: 15 x 21 x 15 blocks).
        let density = &vtk.arrays["density"];
        let mut sorted = density.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[2400];
        assert!(
            sorted[0] > 0.0 && (500.0..2000.0).contains(&median),
            "{median}"
        );
        assert!(vtk.arrays["block"]
            .iter()
            .all(|&b| b >= 0.0 && b < (15 * 21 * 15) as f64));
    }
}

/// Parses a `.vtp` that `fluid-lab export --format vtp` writes (XML header, arrays
/// appended raw with UInt64 sizes): every array by name, as f64, with its components.
fn parse_vtp(bytes: &[u8]) -> HashMap<String, (usize, Vec<f64>)> {
    let marker = b"<AppendedData encoding=\"raw\">";
    let at = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .expect("appended data");
    let header = format!("{}</VTKFile>", std::str::from_utf8(&bytes[..at]).unwrap());
    let document = roxmltree::Document::parse(&header).unwrap();
    let root = document.root_element();
    assert_eq!(root.attribute("type"), Some("PolyData"));
    assert_eq!(root.attribute("byte_order"), Some("LittleEndian"));
    assert_eq!(root.attribute("header_type"), Some("UInt64"));
    let underscore = at
        + marker.len()
        + bytes[at + marker.len()..]
            .iter()
            .position(|&b| b == b'_')
            .unwrap();
    let data = &bytes[underscore + 1..];
    let mut arrays = HashMap::new();
    for array in root.descendants().filter(|n| n.has_tag_name("DataArray")) {
        assert_eq!(array.attribute("format"), Some("appended"));
        let offset: usize = array.attribute("offset").unwrap().parse().unwrap();
        let components: usize = array
            .attribute("NumberOfComponents")
            .unwrap()
            .parse()
            .unwrap();
        let size = u64::from_le_bytes(data[offset..offset + 8].try_into().unwrap()) as usize;
        let raw = &data[offset + 8..offset + 8 + size];
        let values: Vec<f64> = match array.attribute("type").unwrap() {
            "Float32" => raw
                .chunks(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap()) as f64)
                .collect(),
            "Float64" => raw
                .chunks(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
                .collect(),
            "Int32" => raw
                .chunks(4)
                .map(|c| i32::from_le_bytes(c.try_into().unwrap()) as f64)
                .collect(),
            "Int64" => raw
                .chunks(8)
                .map(|c| i64::from_le_bytes(c.try_into().unwrap()) as f64)
                .collect(),
            other => panic!("unexpected type {other}"),
        };
        arrays.insert(
            array.attribute("Name").unwrap().to_string(),
            (components, values),
        );
    }
    assert!(bytes.ends_with(b"</AppendedData>\n</VTKFile>\n"));
    arrays
}

#[test]
fn a_vtp_series_opens_with_physical_times_and_holds_the_states() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let run = |format: &str, folder: &str| {
        let out = dir.path().join(folder);
        let args = [
            small.to_str().unwrap(),
            out.to_str().unwrap(),
            "--steps",
            "2",
        ];
        export(&[
            "export", args[0], args[1], args[2], args[3], "--every", "1", "--format", format,
        ]);
        out
    };
    let (vtp, vtk) = (run("vtp", "vtp"), run("vtk", "vtk"));
    // The collection names every frame with its physical time (1 ms steps).
    let collection = std::fs::read_to_string(vtp.join("small.pvd")).unwrap();
    let document = roxmltree::Document::parse(&collection).unwrap();
    assert_eq!(
        document.root_element().attribute("type"),
        Some("Collection")
    );
    let frames: Vec<(f64, String)> = document
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| {
            let time = n.attribute("timestep").unwrap().parse().unwrap();
            (time, n.attribute("file").unwrap().to_string())
        })
        .collect();
    assert_eq!(frames.len(), 3, "{collection}");
    for (step, (time, file)) in frames.iter().enumerate() {
        assert!((time - step as f64 * 1e-3).abs() < 1e-15, "{time}");
        assert_eq!(file, &format!("small_{step:06}.vtp"));
        let arrays = parse_vtp(&std::fs::read(vtp.join(file)).unwrap());
        // Every array equals the legacy export of the same state, and the points and
        // velocities the input and the reference outputs.
        let legacy =
            parse_vtk(&std::fs::read_to_string(vtk.join(format!("small_{step:06}.vtk"))).unwrap());
        let points: Vec<f64> = legacy.points.iter().flatten().copied().collect();
        assert_eq!(arrays["Points"], (3, points));
        for name in ["velocity", "half_velocity", "density", "block", "id"] {
            assert_eq!(arrays[name].1, legacy.arrays[name], "{file}: {name}");
        }
        let n = 4800;
        assert_eq!(
            arrays["connectivity"].1,
            (0..n).map(f64::from).collect::<Vec<_>>()
        );
        assert_eq!(
            arrays["offsets"].1,
            (1..=n).map(f64::from).collect::<Vec<_>>()
        );
        if step < 2 {
            let truth = match step {
                0 => std::fs::read(&small).unwrap(),
                _ => std::fs::read(reference_output("small", 1)).unwrap(),
            };
            let truth = fld::parse(&truth, file).unwrap().particles;
            for i in 0..n as usize {
                for axis in 0..3 {
                    assert_eq!(arrays["Points"].1[3 * i + axis], truth.p[axis][i]);
                    assert_eq!(arrays["velocity"].1[3 * i + axis], truth.v[axis][i]);
                }
            }
        }
    }
}

#[test]
fn csv_exports_hold_the_final_state_only_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let large = input("large");
    let output = export(&[
        "export",
        large.to_str().unwrap(),
        out,
        "--steps",
        "3",
        "--format",
        "csv",
    ]);
    assert_eq!(
        stdout(&output),
        format!("wrote {out}/large_000003.csv\nwrote {out}/large-frames.csv\n")
    );
    let truth = std::fs::read(reference_output("large", 3)).unwrap();
    let truth = fld::parse(&truth, "large-3.fld").unwrap().particles;
    let text = std::fs::read_to_string(dir.path().join("large_000003.csv")).unwrap();
    let mut rows = text.lines();
    assert_eq!(
        rows.next(),
        Some("id,px,py,pz,hvx,hvy,hvz,vx,vy,vz,density,block")
    );
    let mut count = 0;
    for (i, row) in rows.enumerate() {
        let fields: Vec<f64> = row
            .split(',')
            .map(|v| v.parse::<f32>().unwrap() as f64)
            .collect();
        assert_eq!(fields.len(), 12);
        assert_eq!(fields[0], i as f64);
        for axis in 0..3 {
            assert_eq!(fields[1 + axis], truth.p[axis][i]);
            assert_eq!(fields[4 + axis], truth.hv[axis][i]);
            assert_eq!(fields[7 + axis], truth.v[axis][i]);
        }
        count += 1;
    }
    assert_eq!(count, 15138);
}

fn png_size(path: &Path) -> (u32, u32) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let info = decoder.read_info().unwrap();
    (info.info().width, info.info().height)
}

#[test]
fn renders_write_png_series_and_gif_animations() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let png = dir.path().join("small.png");
    let output = export(&[
        "render",
        small.to_str().unwrap(),
        png.to_str().unwrap(),
        "--steps",
        "2",
        "--every",
        "2",
    ]);
    let series: Vec<_> = [0, 2]
        .iter()
        .map(|step| dir.path().join(format!("small_{step:06}.png")))
        .collect();
    let expected: String = series
        .iter()
        .map(|path| format!("wrote {}\n", path.display()))
        .collect();
    assert_eq!(stdout(&output), expected);
    for path in &series {
        assert_eq!(png_size(path), fluid::lab::render::SIZE);
    }

    let gif = dir.path().join("small.gif");
    let output = export(&[
        "render",
        small.to_str().unwrap(),
        gif.to_str().unwrap(),
        "--steps",
        "4",
        "--every",
        "2",
        "--colour",
        "density",
        "--range",
        "0,2000",
    ]);
    assert_eq!(
        stdout(&output),
        format!("wrote {} (3 frames)\n", gif.display())
    );
    assert!(std::fs::read(&gif).unwrap().starts_with(b"GIF89a"));
}

#[test]
fn a_failed_run_keeps_the_frames_of_its_series_and_says_so_and_no_animation() {
    // Issue 47: a run that fails at its second step (a density diffusion past reason).
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let scene = run_lab(&["scene", "dam-break", &at("dam.fld"), "--ppm", "100"]);
    assert_eq!(exit_code(&scene), 0, "{}", stderr(&scene));
    let failing = |command: &str, output: &str, extra: &[&str]| {
        let mut args = vec![command, "--model", "wcsph", "--density-diffusion", "1e300"];
        args.extend(["--steps", "5", "--every", "1"]);
        args.extend(extra);
        let dam = at("dam.fld");
        let output = at(output);
        args.extend([dam.as_str(), output.as_str()]);
        let run = run_lab(&args);
        assert_eq!(exit_code(&run), 1, "{command}: {}", stderr(&run));
        stderr(&run)
    };
    let failure = "fluid-lab: error: the run failed at step 2: particle 0 is not finite";
    let kept = "; the 2 frames written before it are kept\n";
    assert_eq!(failing("render", "a.png", &[]), format!("{failure}{kept}"));
    assert_eq!(failing("render", "a.gif", &[]), format!("{failure}\n"));
    assert_eq!(
        failing("export", "frames", &["--format", "vtp"]),
        format!("{failure}{kept}")
    );
    let mut left: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|entry| entry.unwrap().file_name().into_string().unwrap())
        .collect();
    left.sort();
    assert_eq!(left, ["a_000000.png", "a_000001.png", "dam.fld", "frames"]);
    let pvd = std::fs::read_to_string(dir.path().join("frames/dam.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet ").count(), 2, "{pvd}");
}

#[test]
fn render_refuses_unknown_outputs_and_empty_ranges() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let jpeg = dir.path().join("x.jpg");
    let output = run_lab(&["render", small.to_str().unwrap(), jpeg.to_str().unwrap()]);
    assert_eq!(exit_code(&output), 2);
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: {}: the output must end in .png or .gif\n",
            jpeg.display()
        )
    );
    let png = dir.path().join("x.png");
    let output = run_lab(&[
        "render",
        small.to_str().unwrap(),
        png.to_str().unwrap(),
        "--range",
        "5,1",
    ]);
    assert_eq!(exit_code(&output), 2);
    // One line, as every error of the workbench.
    assert_eq!(
        stderr(&output),
        "fluid-lab: error: invalid value '5,1' for '--range <RANGE>': 5,1 is empty: LOW must be below HIGH\n"
    );
    assert!(!png.exists());
}

#[test]
fn a_terminal_gets_a_progress_bar_with_steps_per_second() {
    // `script` (util-linux) runs the workbench on a pseudo-terminal.
    let command = format!(
        "{} run --steps 200 {}",
        env!("CARGO_BIN_EXE_fluid-lab"),
        input("large").display()
    );
    let output = std::process::Command::new("script")
        .args(["-q", "-e", "-c", &command, "/dev/null"])
        .output()
        .expect("script (util-linux) runs");
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(text.contains("/200 steps"), "{text}");
    assert!(text.contains("/s"), "{text}");
    let parameters = format!(
        "model=course kernel={} particles=15138 steps=200",
        fluid::Kernel::NATIVE.name()
    );
    assert!(text.contains(&parameters), "{text}");
}

/// The (time, file) of each frame of a `.pvd` collection.
fn collection_frames(path: &Path) -> Vec<(f64, String)> {
    let collection = std::fs::read_to_string(path).unwrap();
    let document = roxmltree::Document::parse(&collection).unwrap();
    document
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| {
            let time = n.attribute("timestep").unwrap().parse().unwrap();
            (time, n.attribute("file").unwrap().to_string())
        })
        .collect()
}

#[test]
fn frames_in_physical_time_land_on_their_times_whatever_the_step() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    // Steps of 0.7 ms against frames every 1 ms to 5 ms: each frame's step is cut short
    // to land on it (0.7 + 0.3 ms), so frame k is step 2k at exactly k ms.
    let out = dir.path().join("series");
    let (small, folder) = (small.to_str().unwrap(), out.to_str().unwrap());
    let args = [
        "export",
        small,
        folder,
        "--model",
        "fluidanimate",
        "--dt",
        "0.0007",
    ];
    let timed = [
        "--until",
        "0.005",
        "--frame-every",
        "0.001",
        "--format",
        "vtp",
    ];
    let output = export(&[&args[..], &timed[..]].concat());
    let frames = collection_frames(&out.join("small.pvd"));
    assert_eq!(frames.len(), 6, "{}", stdout(&output));
    for (k, (time, file)) in frames.iter().enumerate() {
        assert!(
            (time - k as f64 * 1e-3).abs() < 1e-15,
            "frame {k} at {time}"
        );
        assert_eq!(file, &format!("small_{:06}.vtp", 2 * k));
        assert!(out.join(file).is_file());
    }
    // The weakly compressible model's CFL steps on its dam break, cut to land on each
    // frame likewise.
    let dam = dir.path().join("dam.fld");
    let dam = dam.to_str().unwrap();
    export(&["scene", "dam-break", "--ppm", "60", dam]);
    let out = dir.path().join("cfl");
    let folder = out.to_str().unwrap();
    let args = ["export", dam, folder, "--model", "wcsph", "--format", "vtp"];
    export(
        &[
            &args[..],
            &["--until", "0.002", "--frame-every", "0.0005"][..],
        ]
        .concat(),
    );
    let frames = collection_frames(&out.join("dam.pvd"));
    assert_eq!(frames.len(), 5);
    for (k, (time, _)) in frames.iter().enumerate() {
        assert!(
            (time - k as f64 * 5e-4).abs() < 1e-15,
            "frame {k} at {time}"
        );
    }
    // --until alone: the final state only, at that time, after steps cut to reach it.
    let out = dir.path().join("final");
    let folder = out.to_str().unwrap();
    let args = [
        "export",
        small,
        folder,
        "--model",
        "fluidanimate",
        "--dt",
        "0.0007",
    ];
    export(&[&args[..], &["--until", "0.005", "--format", "vtp"][..]].concat());
    let frames = collection_frames(&out.join("small.pvd"));
    assert_eq!(frames.len(), 1);
    assert!((frames[0].0 - 0.005).abs() < 1e-15, "{}", frames[0].0);
    // 0.7 ms steps: 7 whole, then 0.1 ms to land on 5 ms.
    assert_eq!(frames[0].1, "small_000008.vtp");
}

#[test]
fn a_time_that_is_not_finite_and_positive_or_two_extents_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let (small, out) = (small.to_str().unwrap(), dir.path().join("out"));
    let folder = out.to_str().unwrap();
    for (option, value) in [
        ("--until", "-1"),
        ("--until", "0"),
        ("--until", "nan"),
        ("--until", "inf"),
        ("--frame-every", "0"),
        ("--frame-every", "-0.001"),
    ] {
        for subcommand in ["export", "render"] {
            let target = match subcommand {
                "export" => folder.to_string(),
                _ => format!("{folder}.png"),
            };
            let output = run_lab(&[subcommand, small, &target, option, value]);
            assert_eq!(exit_code(&output), 2, "{subcommand} {option} {value}");
            let message = format!("{value} is not a positive, finite time in seconds");
            assert!(stderr(&output).contains(&message), "{}", stderr(&output));
        }
    }
    // A run ends by steps or by time, and writes frames by steps or by time.
    for [option, value, extra, extra_value] in [
        ["--until", "0.01", "--steps", "3"],
        ["--frame-every", "0.001", "--every", "2"],
    ] {
        let output = run_lab(&["export", small, folder, option, value, extra, extra_value]);
        assert_eq!(exit_code(&output), 2);
        assert!(
            stderr(&output).contains("cannot be used with"),
            "{}",
            stderr(&output)
        );
    }
    assert!(!out.exists(), "a refused run leaves no folder");
    assert!(
        !Path::new(&format!("{folder}.png")).exists(),
        "nor a picture"
    );
}

#[test]
fn a_png_series_in_physical_time_has_a_frame_per_interval() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let png = dir.path().join("frame.png");
    let output = run_lab(&[
        "render",
        small.to_str().unwrap(),
        png.to_str().unwrap(),
        "--until",
        "0.003",
        "--frame-every",
        "0.0015",
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    // 1 ms steps: the second is cut to 0.5 ms to land on 1.5 ms (frame at step 2), the
    // third reaches 2.5 ms and the fourth is cut to land on 3 ms (frame at step 4).
    assert_eq!(
        entries(dir.path()),
        ["frame_000000.png", "frame_000002.png", "frame_000004.png"],
        "{}",
        stdout(&output)
    );
}

/// The pixels of the PNG at `path` as RGB rows, and its width.
fn png_pixels(path: &Path) -> (Vec<u8>, usize) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut pixels).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    (pixels, info.width as usize)
}

#[test]
fn a_planar_render_fits_its_frame_to_its_one_view() {
    let dir = tempfile::tempdir().unwrap();
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/dam-break-2d.toml");
    let png = dir.path().join("dam.png");
    let gif = dir.path().join("dam.gif");
    for picture in [&png, &gif] {
        let output = run_lab(&[
            "render".as_ref(),
            "--case".as_ref(),
            case.as_os_str(),
            picture.as_os_str(),
            "--steps".as_ref(),
            "2".as_ref(),
        ]);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    }
    let (width, height) = png_size(&png);
    assert!(
        (560..1280).contains(&width) && height == 560,
        "{width}x{height}"
    );
    let gif_size = gif::DecodeOptions::new()
        .read_info(std::fs::File::open(&gif).unwrap())
        .map(|decoder| (decoder.width() as u32, decoder.height() as u32))
        .unwrap();
    assert_eq!(gif_size, (width, height));
    // Every quarter of the frame's width draws something (the view, then the colour
    // bar and its labels): no blank half.
    let (pixels, width) = png_pixels(&png);
    for quarter in 0..4 {
        let columns = quarter * width / 4..(quarter + 1) * width / 4;
        let drawn = pixels
            .chunks(3)
            .enumerate()
            .filter(|(k, _)| columns.contains(&(k % width)))
            .filter(|(_, rgb)| rgb.iter().any(|&c| c < 200))
            .count();
        assert!(drawn > 100, "quarter {quarter}: {drawn} pixels drawn");
    }
}
