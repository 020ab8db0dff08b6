//! A failed cell stays in its cell: a device broken on purpose in one matrix cell is
//! replaced before the next, and GPU work past the cell limit fails that cell alone, naming
//! the limit.

use crate::common::{self, cli, scratch};

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use clusterlab::compose::Composer;
use clusterlab::gpu::{Gpu, GpuError};
use clusterlab::matrix::{self, CellSpec, Group, MatrixOptions, Sweep};
use clusterlab::render::{RenderError, Renderer};
use clusterlab::scene;

/// The cell whose device the hook destroys.
static BREAK: OnceLock<String> = OnceLock::new();

fn destroy_device_in_chosen_cell(gpu: &Gpu, spec: &CellSpec) {
    if BREAK.get() == Some(&spec.id) {
        gpu.device.destroy();
    }
}

#[test]
fn a_cell_that_breaks_the_device_fails_alone_and_later_cells_get_a_new_one() {
    let mut gpu = common::gpu();
    let groups = [Group {
        name: "device".into(),
        variants: matrix::find_variants(&["forward_plus".into(), "naive_forward".into()])
            .expect("variants"),
        scenes: vec!["one_light".into()],
        sweeps: vec![Sweep::Lights(vec![1, 3])],
        size: Some((48, 27)),
        sequence: None,
    }];
    let cells = matrix::expand(&groups).expect("cells");
    assert_eq!(cells.len(), 4);
    // The first cell: every other cell runs after the break.
    let broken = cells[0].spec.id.clone();
    BREAK.set(broken.clone()).expect("set once");
    let dir = scratch("broken");
    let out = dir.join("results");
    let options = MatrixOptions {
        frames: clusterlab::measure::Frames::exact(0, 1),
        out: out.clone(),
        progress: false,
        shard: None,
        command: vec![],
        variant_files: matrix::variant_files(&cells),
        before_cell: Some(destroy_device_in_chosen_cell),
        reuse: None,
        overlap: false,
    };
    let results = matrix::run(&mut gpu, &Composer::default(), &cells, &options);
    let _ = std::fs::remove_dir_all(&dir);
    for c in &results.cells {
        if c.spec.id == broken {
            let why = c.failure.as_deref().expect("the broken cell fails");
            assert!(
                why.contains("a new one runs the next cells"),
                "the failure says the device was replaced: {why}"
            );
        } else {
            assert!(
                c.ok(),
                "{} after the broken cell: {:?}",
                c.spec.id,
                c.failure
            );
            assert!(c.error.as_ref().is_some_and(|e| e.max_abs_8bit <= 1));
        }
    }
    // The device the matrix hands back is the new one, and it works.
    gpu.check_health().expect("the replacement device works");
}

/// A renderer of naive forward on atrium at `(width, height, lights)`, after its warm-up
/// frame, and the shortest wall time of three frames: the shortest, because a frame slowed by
/// other tests sharing the CPU would set a limit the next, unhindered frame stays under.
fn timed_frame(gpu: &Gpu, (width, height, lights): (u32, u32, u32)) -> (Duration, Renderer<'_>) {
    let params = common::small("atrium", width, height, Some(lights));
    let scene = scene::generate("atrium", params).expect("atrium");
    let v = common::load("naive_forward").variant;
    let mut r = Renderer::new(gpu, &Composer::default(), &v, &scene).expect("renderer");
    r.render().expect("warm-up frame");
    let shortest = (0..3)
        .map(|_| {
            let start = Instant::now();
            r.render().expect("timed frame");
            start.elapsed()
        })
        .min()
        .expect("three frames");
    (shortest, r)
}

#[test]
fn work_past_the_cell_limit_fails_naming_the_limit_and_the_device_is_renewed() {
    let mut gpu = common::gpu();
    // The first frame long enough to time reliably on this adapter: a software GPU stops at
    // the first step, a real one climbs to more lights and pixels.
    let steps = [64, 256, 1024, 4096, 16384, 65536]
        .map(|lights| (160, 90, lights))
        .into_iter()
        .chain([(640, 360, 65536), (1920, 1080, 65536)]);
    let mut frame = None;
    for step in steps {
        let (took, renderer) = timed_frame(&gpu, step);
        frame = Some((took, renderer, step));
        if took >= Duration::from_millis(40) {
            break;
        }
    }
    let (took, mut renderer, step) = frame.expect("a frame");
    assert!(took >= Duration::from_millis(10), "{step:?}: {took:?}");
    let limit = took / 8;
    gpu.set_cell_timeout(limit);
    gpu.begin_cell();
    match renderer.render() {
        Err(RenderError::Gpu(e @ GpuError::TimedOut { .. })) => {
            let message = e.to_string();
            assert!(message.contains("--cell-timeout"), "{message}");
        }
        other => panic!(
            "expected a timeout after {limit:?} ({step:?}, frame {took:?}), got {:?}",
            other.map(|_| ())
        ),
    }
    drop(renderer);
    let broken = gpu.renew_if_unusable().expect("a new device opens");
    assert!(
        matches!(broken, Some(GpuError::TimedOut { .. })),
        "{broken:?}"
    );
    assert_eq!(gpu.cell_timeout(), limit, "the new device keeps the limit");
    gpu.set_cell_timeout(clusterlab::gpu::DEFAULT_CELL_TIMEOUT);
    gpu.check_health().expect("the new device works");
}

/// No adapter is a failure with the install hint, never a silent pass. Metal has no adapter
/// on Linux.
#[cfg(target_os = "linux")]
#[test]
fn no_adapter_fails_with_the_install_hint() {
    let render = [
        "render",
        "--variant",
        "forward_plus",
        "--scene",
        "one_light",
        "--size",
        "8x8",
    ];
    for (args, env) in [
        (&render[..], vec![("WGPU_BACKEND", "metal")]),
        (&["adapters", "--backend", "metal"][..], vec![]),
    ] {
        let (code, text) = cli(args).envs(&env).run().outcome();
        assert_eq!(code, Some(1), "{args:?}: {text}");
        assert!(
            text.contains("no GPU adapter found")
                && text.contains("apt-get install mesa-vulkan-drivers")
                && text.contains("WGPU_BACKEND=gl"),
            "{args:?}: {text}"
        );
    }
    assert!(matches!(
        Gpu::new(Some("metal")),
        Err(GpuError::NoAdapter { .. })
    ));
}

#[test]
fn a_bad_backend_name_is_named_with_where_it_came_from() {
    let (code, text) = cli(["adapters"])
        .envs(&[("WGPU_BACKEND", "vulcan")])
        .run()
        .outcome();
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("`vulcan` (from WGPU_BACKEND) is not a backend"),
        "{text}"
    );
    let (code, text) = cli([
        "render",
        "--variant",
        "forward_plus",
        "--scene",
        "one_light",
        "--backend",
        "vulkan,glx",
    ])
    .run()
    .outcome();
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("`glx` (from --backend) is not a backend"),
        "{text}"
    );
}

#[test]
fn adapters_names_the_one_a_run_uses() {
    let (code, text) = cli(["adapters", "--json"]).run().outcome();
    assert_eq!(code, Some(0), "{text}");
    let survey: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let chosen = survey["chosen"].as_u64().expect("an adapter is chosen") as usize;
    let adapter = &survey["adapters"][chosen];
    let gpu = common::gpu();
    assert_eq!(adapter["name"], gpu.adapter.name.as_str());
    assert_eq!(adapter["backend"], gpu.adapter.backend.as_str());
    assert_eq!(
        adapter["hdr_format"],
        format!("{:?}", gpu.hdr_format).to_lowercase().as_str()
    );
    let required = adapter["capabilities"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["use"].as_str().unwrap().starts_with("required"));
    for c in required {
        assert_eq!(c["present"], true, "the chosen adapter lacks {}", c["name"]);
    }
    let (code, text) = cli(["adapters"]).run().outcome();
    assert_eq!(code, Some(0));
    assert!(
        text.contains(&format!("uses: {}. {}", chosen + 1, gpu.adapter.name)),
        "{text}"
    );
}

/// Mesa's software GPU splits each pass among twice as many threads as cores unless
/// LP_NUM_THREADS says otherwise (`main.rs`); `adapters` names the count under each
/// llvmpipe adapter (Vulkan or OpenGL), and under no other.
#[test]
fn a_software_gpu_splits_passes_among_twice_the_cores_unless_told() {
    let adapters = |threads: Option<&str>| {
        let out = cli(["adapters"])
            .env("LP_NUM_THREADS", threads.unwrap_or(""))
            .run();
        assert_eq!(out.code, Some(0), "{}", out.stderr);
        out.stdout
    };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    for (set, shown) in [
        (None, (2 * cores).to_string()),
        (Some("3"), "3".to_string()),
    ] {
        let text = adapters(set);
        // Adapter headings: "N. NAME (backend, type)".
        let software = text
            .lines()
            .filter_map(|l| l.split_once(". "))
            .filter(|(n, name)| n.parse::<u32>().is_ok() && name.starts_with("llvmpipe"))
            .count();
        let line = format!("\n   threads per pass: {shown} (LP_NUM_THREADS)\n");
        assert_eq!(text.matches(&line).count(), software, "{text}");
        assert_eq!(text.matches("threads per pass").count(), software, "{text}");
    }
}
