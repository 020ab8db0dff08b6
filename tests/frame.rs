//! The frame as data (`render::frame`): every shipped variant's frame is laid out with a
//! typed name for every binding, no step reads what the GPU builds before a step of the
//! frame wrote it, and every entry point the renderer names is a shader's.

use clusterlab::compose::Composer;
use clusterlab::render::frame::Work;
use clusterlab::render::{Binding, Frame, Step, frame_of};
use clusterlab::variant::{Assignment, Variant};
use strum::IntoEnumIterator;

fn shipped() -> Vec<clusterlab::variant::LoadedVariant> {
    clusterlab::variant::load_args(&["variants".to_string()]).expect("the shipped variants")
}

/// What a frame reads that no step of it builds: what the CPU uploads (the view, the occluders, the
/// lights, textures, the moving set, the sampler's frame, the starting cluster range;
/// the lists themselves with CPU assignment), and what a frame keeps for the next (the
/// sampled loops' reservoirs of the frame before).
fn given(v: &Variant, b: Binding) -> bool {
    use Binding::*;
    let cpu_lists = v.pipeline.is_clustered() && v.clusters().assignment == Assignment::Cpu;
    matches!(
        b,
        View | Lights
            | BaseColorTextures
            | BaseColorSampler
            | MovingLights
            | MovingMask
            | Occluders
            | SampleFrame
            | ClusterRange
            | PreviousReservoirs
    ) || cpu_lists && matches!(b, LightCounts | LightOffsets | LightIndices)
}

/// The reads of `steps` that no earlier step wrote or rendered into: "step reads name".
/// A post step's images in are the chain's own (`post`), which starts from the shaded
/// `hdr`.
fn unwritten(v: &Variant, steps: &[Step]) -> Vec<String> {
    let mut written: Vec<Binding> = Vec::new();
    let mut found = Vec::new();
    for s in steps {
        let post = s.work == Work::Post;
        for r in &s.reads {
            let chain = post
                && written.contains(&Binding::Hdr)
                && matches!(
                    r,
                    Binding::HdrIn | Binding::BrightIn | Binding::BlurIn | Binding::BlurredIn
                );
            if !given(v, *r) && !written.contains(r) && !chain {
                found.push(format!("{} reads {}", s.pass.name(), r.name()));
            }
        }
        written.extend(&s.writes);
        // An image rendered into is read by its binding's name (depth, the G-buffer, hdr).
        written.extend(s.attachments.iter().filter_map(|a| match *a {
            "depth" => Some(Binding::DepthTexture),
            name => name.parse().ok(),
        }));
    }
    found
}

#[test]
fn every_step_reads_what_an_earlier_step_wrote() {
    let composer = Composer::default();
    let mut wrong = Vec::new();
    for v in shipped() {
        let frame: Frame =
            frame_of(&composer, &v.variant).unwrap_or_else(|e| panic!("{}: {e}", v.name));
        assert!(!frame.steps.is_empty(), "{}: no steps", v.name);
        for read in unwritten(&v.variant, &frame.steps) {
            wrong.push(format!("{}: {read}", v.name));
        }
        // The deliberate break: shading moved before what builds its lists.
        if v.name == "forward_plus" {
            let mut swapped = frame.steps.clone();
            let shade = swapped
                .iter()
                .position(|s| s.pass.name() == "forward")
                .unwrap();
            let step = swapped.remove(shade);
            swapped.insert(0, step);
            assert!(
                unwritten(&v.variant, &swapped)
                    .iter()
                    .any(|r| r == "forward reads light_counts"),
                "shading before light assignment is not caught"
            );
        }
    }
    assert!(wrong.is_empty(), "reads before any write: {wrong:#?}");
}

/// Every binding the shaders declare is a `Binding`, and every `Binding` is declared by
/// some shader: the enum and the WGSL name the same set. The deliberate break: a name one
/// letter off is refused, naming the nearest.
#[test]
fn binding_names_are_the_shaders_own() {
    let err = Binding::declared("forward", "light_count")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("`light_count`") && err.contains("light_counts"),
        "{err}"
    );
    let mut declared = Vec::new();
    let mut files = Vec::new();
    wgsl_files(std::path::Path::new("shaders"), &mut files);
    for file in files {
        let is_kernel = file.to_string_lossy().contains("kernel_");
        let text = std::fs::read_to_string(&file).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines
            .iter()
            .enumerate()
            .filter(|(_, l)| l.contains("@binding("))
        {
            // `@group(g) @binding(b) var ...`, or the `var` on the next line.
            let line = if line.contains("var") {
                line
            } else {
                lines.get(i + 1).unwrap_or(line)
            };
            let Some(after) = line.split("var").nth(1) else {
                continue;
            };
            // `var<storage, read> name` or `var name`.
            let after = match after.strip_prefix('<') {
                Some(space) => space.split_once('>').map_or(space, |(_, rest)| rest),
                None => after,
            };
            let name: String = after
                .trim_start()
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !is_kernel && !name.is_empty() {
                declared.push(name);
            }
        }
    }
    for name in &declared {
        assert!(
            Binding::declared("any", name).is_ok(),
            "shaders declare `{name}`, which is no Binding"
        );
    }
    for b in Binding::iter() {
        assert!(
            declared.iter().any(|d| d == b.name()),
            "Binding::{b:?} (`{}`) is declared by no shader",
            b.name()
        );
    }
}

fn wgsl_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            wgsl_files(&path, out);
        } else if path.extension().is_some_and(|x| x == "wesl") {
            out.push(path);
        }
    }
}

/// `wgsl --frame` prints the frame a newcomer reads: each pass in order with what it reads,
/// writes and does.
#[test]
fn wgsl_frame_prints_the_steps_in_order() {
    let out = crate::common::cli(["wgsl", "forward_plus", "--frame"]).run();
    assert_eq!(out.code, Some(0), "{}", out.printed());
    let at = |name: &str| {
        out.stdout
            .find(name)
            .unwrap_or_else(|| panic!("no {name}:\n{}", out.stdout))
    };
    assert!(at(". light_assign") < at(". forward"), "{}", out.stdout);
    assert!(out.stdout.contains("writes"), "{}", out.stdout);
    assert!(out.stdout.contains("into   hdr"), "{}", out.stdout);
}

/// The entry points the renderer names (`get("reduce")`, a dispatch step, a pipeline's
/// `("vs_main", "fs_main")`, a post step): each as Rust writes it.
fn named_entries(source: &str) -> Vec<String> {
    let mut found = Vec::new();
    for line in source.lines() {
        let code = line.split("//").next().unwrap_or("");
        let literals: Vec<&str> = code.split('"').skip(1).step_by(2).collect();
        let entry_context = [
            "get(",
            "groups_for(",
            "Step::Dispatch(",
            "Step::Indirect(",
            "long_lists(",
            "Over::",
            "ComputePipelines::new(",
            "step(pass, ",
        ]
        .iter()
        .any(|c| code.contains(c));
        for l in literals {
            let is_name = !l.is_empty() && l.chars().all(|c| c.is_ascii_lowercase() || c == '_');
            let shader_prefix = ["vs_", "fs_", "cs_"].iter().any(|p| l.starts_with(p));
            if is_name && (shader_prefix || entry_context) {
                found.push(l.to_string());
            }
        }
    }
    found
}

/// The entry points the shaders declare: each function after `@compute`, `@fragment` or
/// `@vertex`.
fn shader_entries() -> Vec<String> {
    let mut files = Vec::new();
    wgsl_files(std::path::Path::new("shaders"), &mut files);
    let mut entries = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        let mut stage = false;
        for line in text.lines() {
            let line = line.trim_start();
            stage |= ["@compute", "@fragment", "@vertex"]
                .iter()
                .any(|s| line.contains(s));
            if let Some(rest) = line.split("fn ").nth(1).filter(|_| stage) {
                entries.push(rest.split('(').next().unwrap_or("").trim().to_string());
                stage = false;
            }
        }
    }
    entries
}

/// Every entry point the renderer names is one a shader declares: a misspelt entry fails
/// here rather than when a frame first needs it. The deliberate break: `get("reduc")`.
#[test]
fn every_entry_the_renderer_names_is_a_shaders() {
    let entries = shader_entries();
    assert!(entries.iter().any(|e| e == "reduce") && entries.iter().any(|e| e == "fs_main"));
    let unknown = |source: &str| -> Vec<String> {
        named_entries(source)
            .into_iter()
            .filter(|n| !entries.contains(n))
            .collect()
    };
    assert_eq!(unknown("cp.set_pipeline(p.get(\"reduc\"));"), ["reduc"]);
    let mut sources = Vec::new();
    crate::common::rust_sources(std::path::Path::new("src/render"), &mut sources);
    let mut wrong = Vec::new();
    let mut named = 0;
    for file in sources {
        let text = std::fs::read_to_string(&file).unwrap();
        named += named_entries(&text).len();
        for n in unknown(&text) {
            wrong.push(format!("{}: `{n}`", file.display()));
        }
    }
    // The scan finds the renderer's entries at all (more than the screen passes' own).
    assert!(named > 40, "only {named} entry names found");
    assert!(wrong.is_empty(), "entries no shader declares: {wrong:#?}");
}
