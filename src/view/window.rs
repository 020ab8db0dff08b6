//! The window: winit's event loop, egui's panel and the frame, painted by `egui-wgpu`.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::thread::Scope;
use std::time::Instant;

use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::window::{Window, WindowId};

use super::ViewOptions;
use super::fly::{Fly, Thrust};
use super::jobs::{self, Done, Job, Subject};
use super::script::{Change, Step, WAIT_LIMIT_S};
use super::session::{Session, Setup};
use super::watch::{Changed, Watch};
use crate::gpu::Gpu;
use crate::scene::{CameraPose, FRAME_DT};
use crate::sequence::animation::{ANIMATION_FRAMES, Thumbnail};
use crate::variant::{DebugView, SAMPLE_COUNTS, ShadowSampler, ShadowSampling, Shadows};

/// A change on disk woke the loop.
struct Wake;

/// Longest step of flight one frame makes, seconds (a frame that took longer flies as if
/// it had not, so a slow frame does not throw the camera across the scene).
const MAX_FLIGHT_DT: f32 = 0.1;
/// Width of the panel, points.
const PANEL_WIDTH: f32 = 330.0;

/// Why there is no window to open, if there is none: on Linux and the BSDs a window needs
/// an X11 or Wayland display.
pub fn missing_display() -> Option<String> {
    let unix_desktop = cfg!(all(
        unix,
        not(target_os = "macos"),
        not(target_os = "android")
    ));
    let display = ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| crate::environment::var_os(v).is_some_and(|d| !d.is_empty()));
    (unix_desktop && !display).then(|| {
        "`view` opens a window and this machine has no display (neither DISPLAY nor WAYLAND_DISPLAY is set): run it under a virtual one, `xvfb-run -a clusterlab view ...` (Debian's package xvfb); every other command needs none".to_string()
    })
}

/// Open the window and run until it is closed or the script ends: `Ok(false)` when a
/// script step failed.
pub fn run(options: ViewOptions, gpu: &Gpu) -> Result<bool, String> {
    if let Some(why) = missing_display() {
        return Err(why);
    }
    open(options, gpu)
}

fn open(options: ViewOptions, gpu: &Gpu) -> Result<bool, String> {
    let steps = options
        .script
        .as_deref()
        .map(super::script::load)
        .transpose()?;
    let event_loop = EventLoop::<Wake>::with_user_event().build().map_err(|e| {
        format!("cannot open a window: {e}; on a machine without a display run `xvfb-run -a clusterlab view ...`")
    })?;
    let mut session = Session::new(
        gpu,
        Setup {
            variant: options.variant.clone(),
            debug_view: DebugView::Off,
            samples: 1,
            shadows: Shadows::None,
            scene: options.scene.clone(),
            params: options.params,
            camera: options.camera,
        },
    );
    session.setup = session.setup_for_variant(options.variant.clone())?;
    let mut folders: Vec<PathBuf> = options
        .variants
        .iter()
        .filter_map(|v| {
            v.parent().map(|p| {
                if p.as_os_str().is_empty() {
                    Path::new(".")
                } else {
                    p
                }
            })
        })
        .map(Path::to_path_buf)
        .collect();
    folders.sort();
    folders.dedup();
    let proxy = event_loop.create_proxy();
    let watch = Watch::new(session.composer().shader_root(), &folders, move || {
        let _ = proxy.send_event(Wake);
    })?;
    let painter = pollster::block_on(egui_wgpu::winit::Painter::new(
        egui::Context::default(),
        egui_wgpu::WgpuConfiguration {
            wgpu_setup: egui_wgpu::WgpuSetup::from_display_handle(
                event_loop.owned_display_handle(),
            ),
            ..Default::default()
        },
        false,
        egui_wgpu::RendererOptions {
            dithering: false,
            ..Default::default()
        },
    ));
    let base = options.out.clone();
    std::thread::scope(|scope| {
        let mut app = App {
            scope,
            gpu,
            ctx: egui::Context::default(),
            painter,
            window: None,
            egui_state: None,
            session,
            watch,
            options,
            texture: None,
            texture_frame: 0,
            fly: None,
            thrust: Thrust::default(),
            last_frame: Instant::now(),
            playing: false,
            job: None,
            note: None,
            job_failure: None,
            recording: None,
            player: steps.map(|s| Player::new(s, base)),
            reloads: 0,
            failure: None,
            fatal: None,
        };
        event_loop
            .run_app(&mut app)
            .map_err(|e| format!("the window's event loop failed: {e}"))?;
        if let Some(e) = app.fatal {
            return Err(e);
        }
        match app.failure {
            Some(why) => {
                eprintln!("error: script: {why}");
                Ok(false)
            }
            None => Ok(true),
        }
    })
}

/// A recording under way.
struct Recording {
    frames: Vec<Thumbnail>,
    /// Frames still to record (a script's), or `None` until stopped (R).
    left: Option<u32>,
    /// The frame count when the last thumbnail was taken.
    last: u64,
}

/// A window screenshot asked for, and its result once written.
type ShotSlot = Arc<Mutex<Option<Result<(), String>>>>;

struct App<'s, 'e> {
    scope: &'s Scope<'s, 'e>,
    gpu: &'e Gpu,
    ctx: egui::Context,
    painter: egui_wgpu::winit::Painter,
    window: Option<Arc<Window>>,
    egui_state: Option<egui_winit::State>,
    session: Session<'e>,
    watch: Watch,
    options: ViewOptions,
    texture: Option<egui::TextureHandle>,
    /// The session's frame count when the texture was last filled.
    texture_frame: u64,
    /// The flown camera, once the camera moved off the scene's own.
    fly: Option<Fly>,
    /// What the held keys fly, read from the last frame's input.
    thrust: Thrust,
    last_frame: Instant,
    playing: bool,
    job: Option<Job>,
    /// The last job's outcome, for the panel.
    note: Option<String>,
    /// Why the last job failed, until a script's step that waits for it has seen it.
    job_failure: Option<String>,
    recording: Option<Recording>,
    player: Option<Player>,
    /// Batches of changes on disk handled so far.
    reloads: u64,
    /// Why the script failed, once it did.
    failure: Option<String>,
    /// A failure that ends the viewer (no window, no surface).
    fatal: Option<String>,
}

impl ApplicationHandler<Wake> for App<'_, '_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let (w, h) = (
            self.session.setup.params.width,
            self.session.setup.params.height,
        );
        let attributes = Window::default_attributes()
            .with_title("clusterlab view")
            .with_inner_size(winit::dpi::LogicalSize::new(
                w as f64 + PANEL_WIDTH as f64 + 24.0,
                (h as f64 + 220.0).max(960.0),
            ));
        let window = match event_loop.create_window(attributes) {
            Ok(w) => Arc::new(w),
            Err(e) => {
                self.fatal = Some(format!("cannot open a window: {e}"));
                event_loop.exit();
                return;
            }
        };
        if let Err(e) = pollster::block_on(
            self.painter
                .set_window(egui::ViewportId::ROOT, Some(Arc::clone(&window))),
        ) {
            self.fatal = Some(format!("cannot paint into the window: {e}"));
            event_loop.exit();
            return;
        }
        self.egui_state = Some(egui_winit::State::new(
            self.ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            self.painter.max_texture_side(),
        ));
        window.request_redraw();
        self.window = Some(window);
    }

    fn user_event(&mut self, _: &ActiveEventLoop, _: Wake) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let (Some(window), Some(state)) = (self.window.clone(), self.egui_state.as_mut()) else {
            return;
        };
        let response = state.on_window_event(&window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let (Some(w), Some(h)) = (
                    std::num::NonZeroU32::new(size.width),
                    std::num::NonZeroU32::new(size.height),
                ) {
                    self.painter.on_window_resized(egui::ViewportId::ROOT, w, h);
                }
                window.request_redraw();
            }
            WindowEvent::RedrawRequested => {
                self.frame(event_loop, &window);
            }
            _ if response.repaint => window.request_redraw(),
            _ => {}
        }
    }
}

impl App<'_, '_> {
    /// One frame: changes on disk, the script, flight and time, the renderer's frame, the
    /// panel, and paint.
    fn frame(&mut self, event_loop: &ActiveEventLoop, window: &Arc<Window>) {
        let changes = self.watch.changes();
        for c in &changes {
            match c {
                Changed::Shaders => self.session.shaders_changed(),
                Changed::Variants => self.session.dirty = true,
            }
        }
        if !changes.is_empty() {
            self.reloads += 1;
        }
        let scripted = self.player.is_some();
        if let Some(mut player) = self.player.take() {
            match player.tick(self) {
                Ok(true) => event_loop.exit(),
                Ok(false) => self.player = Some(player),
                Err(why) => {
                    self.failure = Some(why);
                    event_loop.exit();
                }
            }
        }
        // A script flies a frame step a frame, whatever the frame took: its frames are the
        // same on every machine.
        let dt = if scripted {
            FRAME_DT as f32
        } else {
            self.last_frame.elapsed().as_secs_f32().min(MAX_FLIGHT_DT)
        };
        self.last_frame = Instant::now();
        let thrust = self.thrust_now();
        if thrust != Thrust::default() {
            self.fly_by(|fly| fly.fly(thrust, dt));
        }
        if self.playing {
            self.session.step_time(1);
        }
        self.session.draw();
        self.take_job();
        self.record();
        self.show_frame();

        let Some(state) = self.egui_state.as_mut() else {
            return;
        };
        let input = state.take_egui_input(window);
        let ctx = self.ctx.clone();
        let mut full = ctx.run_ui(input, |ui| self.ui(ui));
        let state = self.egui_state.as_mut().expect("made on resume");
        state.handle_platform_output(window, std::mem::take(&mut full.platform_output));
        let mut captures = Vec::new();
        for (_, output) in std::mem::take(&mut full.viewport_output) {
            for command in output.commands {
                if let egui::ViewportCommand::Screenshot(callback) = command {
                    captures.push(callback);
                }
            }
        }
        let primitives = ctx.tessellate(std::mem::take(&mut full.shapes), full.pixels_per_point);
        self.painter.paint_and_update_textures(
            egui::ViewportId::ROOT,
            full.pixels_per_point,
            [0.08, 0.08, 0.08, 1.0],
            &primitives,
            &mut full.textures_delta,
            captures,
            window,
        );
        let busy = self.playing
            || self.session.dirty
            || self.job.is_some()
            || self.recording.is_some()
            || self.player.is_some()
            || thrust != Thrust::default()
            || ctx.has_requested_repaint();
        if busy {
            window.request_redraw();
        }
    }

    /// The held keys' flight: the window's keys, and a script's.
    fn thrust_now(&self) -> Thrust {
        let mut t = self.thrust;
        if let Some(p) = &self.player {
            for (key, _) in &p.held {
                let (f, r, u) = key_thrust(key);
                (t.forward, t.right, t.up) = (t.forward + f, t.right + r, t.up + u);
            }
        }
        t
    }

    /// Change the flown camera (starting it on the shown camera) and draw from it.
    fn fly_by(&mut self, change: impl FnOnce(&mut Fly)) {
        let fly = match (&mut self.fly, &self.session.shown) {
            (Some(f), _) => f,
            (None, Some(shown)) => self.fly.insert(Fly::on(&shown.scene.camera)),
            (None, None) => return,
        };
        change(fly);
        let mut setup = self.session.setup.clone();
        setup.camera = Some(fly.pose());
        self.session.change(setup);
    }

    /// Back on the scene's own camera.
    fn scene_camera(&mut self) {
        self.fly = None;
        let mut setup = self.session.setup.clone();
        setup.camera = None;
        self.session.change(setup);
    }

    /// Fill the frame's texture when a new frame was drawn.
    fn show_frame(&mut self) {
        let Some(shown) = &self.session.shown else {
            return;
        };
        if self.texture.is_some() && self.texture_frame == self.session.frames {
            return;
        }
        let f = &shown.frame;
        let rgba: Vec<u8> = f.ldr.iter().flat_map(|p| [p[0], p[1], p[2], 255]).collect();
        let image =
            egui::ColorImage::from_rgba_unmultiplied([f.width as usize, f.height as usize], &rgba);
        match &mut self.texture {
            Some(t) => t.set(image, egui::TextureOptions::NEAREST),
            None => {
                self.texture = Some(self.ctx.load_texture(
                    "frame",
                    image,
                    egui::TextureOptions::NEAREST,
                ))
            }
        }
        self.texture_frame = self.session.frames;
    }

    /// What a job needs: the shown frame and what drew it.
    fn subject(&self) -> Option<Subject> {
        let shown = self.session.shown.as_ref()?;
        Some(Subject {
            frame: shown.frame.clone(),
            variant: shown.variant.clone(),
            scene: shown.scene.clone(),
            composer: self.session.composer().clone(),
            command: self.render_command(&shown.setup),
        })
    }

    fn render_command(&self, setup: &Setup) -> String {
        let file = crate::variant::load(&setup.variant).map(|v| v.variant).ok();
        jobs::render_command(setup, file.as_ref())
    }

    /// Start a screenshot of the shown frame; why not, when there is none (or a job runs).
    fn start_screenshot(&mut self) -> Result<(), String> {
        let subject = self.job_subject()?;
        self.job = Some(Job::screenshot(
            self.scope,
            self.gpu,
            subject,
            self.options.out.clone(),
        ));
        Ok(())
    }

    /// Start measuring the shown frame's error; why not, when there is no frame.
    fn start_error(&mut self) -> Result<(), String> {
        let subject = self.job_subject()?;
        self.job = Some(Job::error(self.scope, self.gpu, subject));
        Ok(())
    }

    fn job_subject(&self) -> Result<Subject, String> {
        if let Some(job) = &self.job {
            return Err(format!("the {} under way has not finished", job.what));
        }
        self.subject().ok_or_else(|| match &self.session.error {
            Some(e) => format!("no frame is shown: {e}"),
            None => "no frame is shown yet".into(),
        })
    }

    /// The job's outcome, once it has one.
    fn take_job(&mut self) {
        let Some(job) = &self.job else { return };
        let Some(result) = job.take() else { return };
        self.note = Some(match result {
            Ok(Done::Error(e)) => format!(
                "error against the f64 reference: max {} LSB, RMSE {:.3} LSB, {} pixels over 1 LSB, FLIP {:.4}",
                e.max_abs_8bit, e.rmse_8bit, e.pixels_over_1lsb, e.flip_mean
            ),
            Ok(Done::Screenshot(files)) => {
                let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
                format!("wrote {}", names.join(", "))
            }
            Err(e) => {
                let why = format!("{} failed: {e}", job.what);
                self.job_failure = Some(why.clone());
                why
            }
        });
        if let Some(note) = &self.note {
            println!("{note}");
        }
        self.job = None;
    }

    fn start_recording(&mut self, frames: Option<u32>) {
        self.recording = Some(Recording {
            frames: Vec::new(),
            left: frames,
            last: self.session.frames,
        });
    }

    /// Add the frame drawn since the last one to the recording, and finish it when done.
    fn record(&mut self) {
        let Some(rec) = &mut self.recording else {
            return;
        };
        if let Some(shown) = &self.session.shown
            && self.session.frames != rec.last
        {
            rec.last = self.session.frames;
            rec.frames
                .push(crate::sequence::animation::thumbnail(&shown.frame));
            if let Some(left) = &mut rec.left {
                *left = left.saturating_sub(1);
            }
        }
        let full = rec.frames.len() as u32 >= ANIMATION_FRAMES;
        if rec.left == Some(0) || full {
            self.stop_recording();
        }
    }

    fn stop_recording(&mut self) {
        let Some(rec) = self.recording.take() else {
            return;
        };
        let Some(shown) = &self.session.shown else {
            return;
        };
        let stem =
            crate::run::safe_file_name(&format!("{}@{}", shown.variant.name, shown.scene.name));
        let path = self.options.out.join(format!("{stem}.view.gif"));
        let written = crate::sequence::animation::gif(&rec.frames, FRAME_DT).and_then(|gif| {
            crate::files::write::create_folder(&self.options.out)?;
            crate::files::write_file(&path, &gif)
        });
        self.note = Some(match written {
            Ok(()) => format!("wrote {} ({} frames)", path.display(), rec.frames.len()),
            Err(e) => format!("recording failed: {e}"),
        });
        println!("{}", self.note.as_deref().unwrap_or_default());
    }

    /// Ask for the window as painted this frame to be written to `path`.
    fn window_shot(&self, file: PathBuf) -> ShotSlot {
        let slot: ShotSlot = Arc::new(Mutex::new(None));
        let done = Arc::clone(&slot);
        self.ctx.request_screenshot(move |image| {
            let rgb: Vec<u8> = image
                .pixels
                .iter()
                .flat_map(|c| [c.r(), c.g(), c.b()])
                .collect();
            let [w, h] = image.size;
            let written = file
                .parent()
                .map_or(Ok(()), crate::files::write::create_folder)
                .and_then(|()| {
                    crate::run::write_png(&file, w as u32, h as u32, &rgb)
                        .map_err(|e| e.to_string())
                });
            *done.lock().expect("a screenshot's slot is not poisoned") = Some(written);
        });
        slot
    }

    /// What the viewer shows, for a script's `State` step.
    fn state_json(&self) -> serde_json::Value {
        use sha2::Digest;
        let shown = self.session.shown.as_ref().map(|s| {
            let rgb: Vec<u8> = s.frame.ldr.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
            serde_json::json!({
                "variant": s.variant.name,
                "scene": s.scene.name,
                "size": [s.frame.width, s.frame.height],
                "time": s.setup.params.time,
                "lights": s.scene.lights.len(),
                "camera": CameraPose::of(&s.scene.camera).argument(),
                "render_command": self.render_command(&s.setup),
                "image_sha256": format!("{:x}", sha2::Sha256::digest(&rgb)),
                "timing_source": if s.frame.timings.gpu_timestamps { "gpu timestamps" } else { "wall clock" },
                "gpu_ms": s.frame.timings.passes,
                "light_evals": s.stats.as_ref().map(|st| st.light_evals),
                "useful_light_evals": s.stats.as_ref().map(|st| st.useful_light_evals),
                "dropped_lights": s.stats.as_ref().map(|st| st.dropped_lights),
            })
        });
        serde_json::json!({
            "frames": self.session.frames,
            "reloads": self.reloads,
            "error": self.session.error,
            "shown": shown,
            "note": self.note,
        })
    }

    /// The panel beside the frame.
    fn ui(&mut self, ui: &mut egui::Ui) {
        egui::Panel::left("controls")
            .resizable(false)
            .exact_size(PANEL_WIDTH)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui));
            });
        egui::CentralPanel::default().show(ui, |ui| self.picture(ui));
        self.keys(ui);
    }

    /// The frame at one image pixel per screen pixel; dragging it turns the camera, the
    /// wheel over it sets the speed.
    fn picture(&mut self, ui: &mut egui::Ui) {
        if let Some(e) = &self.session.error {
            egui::Frame::new()
                .fill(egui::Color32::from_rgb(80, 20, 20))
                .inner_margin(6.0)
                .show(ui, |ui| {
                    ui.colored_label(
                        egui::Color32::WHITE,
                        "the last change cannot be drawn; the last good frame stays:",
                    );
                    ui.monospace(e);
                });
        }
        let Some(texture) = &self.texture else {
            ui.label("drawing the first frame...");
            return;
        };
        let ppp = ui.ctx().pixels_per_point();
        let size = texture.size_vec2() / ppp;
        let response = ui.add(
            egui::Image::new(egui::load::SizedTexture::new(texture.id(), size))
                .sense(egui::Sense::drag()),
        );
        let drag = response.drag_delta() * ppp;
        if drag != egui::Vec2::ZERO {
            self.fly_by(|fly| fly.turn(drag.x, drag.y));
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.fly_by(|fly| fly.wheel(scroll / 50.0));
            }
        }
    }

    /// Keys, when no text field has them.
    fn keys(&mut self, ui: &mut egui::Ui) {
        use egui::Key;
        if ui.ctx().egui_wants_keyboard_input() {
            self.thrust = Thrust::default();
            return;
        }
        let (down, pressed) = ui.input(|i| {
            let down = |k: Key| if i.key_down(k) { 1.0 } else { 0.0 };
            (
                Thrust {
                    forward: down(Key::W) - down(Key::S),
                    right: down(Key::D) - down(Key::A),
                    up: down(Key::E) - down(Key::Q),
                },
                [Key::Space, Key::Period, Key::Home, Key::P, Key::R, Key::C]
                    .into_iter()
                    .filter(|&k| i.key_pressed(k))
                    .collect::<Vec<_>>(),
            )
        });
        self.thrust = down;
        for key in pressed {
            self.press(key.name());
        }
    }

    /// A key that does something once: by the name the script and egui give it.
    fn press(&mut self, key: &str) {
        match key {
            "Space" => self.playing = !self.playing,
            "Period" => self.session.step_time(1),
            "Home" => self.scene_camera(),
            "P" => self.note = self.start_screenshot().err(),
            "R" => {
                if self.recording.is_some() {
                    self.stop_recording()
                } else {
                    self.start_recording(None)
                }
            }
            "C" => {
                if let Some(s) = &self.session.shown {
                    let command = self.render_command(&s.setup);
                    println!("{command}");
                    self.ctx.copy_text(command);
                }
            }
            _ => {}
        }
    }

    fn controls(&mut self, ui: &mut egui::Ui) {
        let mut setup = self.session.setup.clone();
        ui.heading("clusterlab view");
        ui.label(format!(
            "{} ({}, {})",
            self.gpu.adapter.name, self.gpu.adapter.backend, self.gpu.adapter.driver
        ));
        ui.separator();

        let mut chosen = None;
        egui::ComboBox::from_label("variant")
            .selected_text(variant_name(&setup.variant))
            .width(200.0)
            .show_ui(ui, |ui| {
                for v in &self.options.variants {
                    if ui
                        .selectable_label(*v == setup.variant, variant_name(v))
                        .clicked()
                    {
                        chosen = Some(v.clone());
                    }
                }
            });
        if let Some(v) = chosen {
            match self.session.setup_for_variant(v) {
                Ok(s) => setup = s,
                Err(e) => self.session.error = Some(e),
            }
        }
        let mut scene = setup.scene.clone();
        egui::ComboBox::from_label("scene")
            .selected_text(&scene)
            .width(200.0)
            .show_ui(ui, |ui| {
                let mut names: Vec<String> = crate::scene::SCENES
                    .iter()
                    .map(|s| s.name.to_string())
                    .collect();
                if !names.contains(&self.options.scene) {
                    names.push(self.options.scene.clone());
                }
                for n in names {
                    ui.selectable_value(&mut scene, n.clone(), n);
                }
            });
        if scene != setup.scene {
            match crate::scene::defaults(&scene) {
                Ok(p) => {
                    setup.params = p;
                    setup.scene = scene;
                    setup.camera = None;
                    self.fly = None;
                }
                Err(e) => self.session.error = Some(e.to_string()),
            }
        }
        let p = &mut setup.params;
        ui.add(
            egui::Slider::new(&mut p.lights, 0..=65536)
                .logarithmic(true)
                .text("lights"),
        );
        ui.horizontal(|ui| {
            ui.add(
                egui::DragValue::new(&mut p.radius_range.0)
                    .range(0.01..=p.radius_range.1)
                    .speed(0.05),
            );
            ui.add(
                egui::DragValue::new(&mut p.radius_range.1)
                    .range(p.radius_range.0..=1000.0)
                    .speed(0.05),
            );
            ui.label("light radius");
        });
        ui.add(egui::Slider::new(&mut p.spots, 0.0..=1.0).text("spot fraction"));
        ui.horizontal(|ui| {
            ui.add(egui::DragValue::new(&mut p.seed));
            ui.label("seed");
        });
        ui.horizontal(|ui| {
            ui.add(
                egui::DragValue::new(&mut p.time)
                    .range(0.0..=crate::scene::MAX_TIME_S)
                    .speed(0.01)
                    .suffix(" s"),
            );
            let play = if self.playing { "pause" } else { "play" };
            if ui.button(play).clicked() {
                self.playing = !self.playing;
            }
            if ui.button("step").clicked() {
                p.time = (p.time + FRAME_DT).min(crate::scene::MAX_TIME_S);
            }
        });
        egui::ComboBox::from_label("debug view")
            .selected_text(setup.debug_view.name())
            .width(200.0)
            .show_ui(ui, |ui| {
                for v in DebugView::every() {
                    ui.selectable_value(&mut setup.debug_view, v, v.name());
                }
            });
        let offered = self.gpu.multisample_counts();
        egui::ComboBox::from_label("samples per pixel")
            .selected_text(setup.samples.to_string())
            .show_ui(ui, |ui| {
                for n in SAMPLE_COUNTS.into_iter().filter(|n| offered.contains(n)) {
                    ui.selectable_value(&mut setup.samples, n, n.to_string());
                }
            });
        egui::ComboBox::from_label("shadows")
            .selected_text(setup.shadows.label())
            .width(200.0)
            .show_ui(ui, |ui| {
                for s in shadow_choices(setup.shadows) {
                    ui.selectable_value(&mut setup.shadows, s, s.label());
                }
            });
        ui.label("Other options: edit the variant file; it reloads on save.");
        self.session.change(setup);
        ui.separator();

        self.camera_section(ui);
        ui.separator();
        self.counter_section(ui);

        ui.horizontal(|ui| {
            if ui
                .add_enabled(self.job.is_none(), egui::Button::new("measure error"))
                .clicked()
            {
                self.note = self.start_error().err();
            }
            if ui
                .add_enabled(self.job.is_none(), egui::Button::new("screenshot (P)"))
                .clicked()
            {
                self.note = self.start_screenshot().err();
            }
            let rec = if self.recording.is_some() {
                "stop (R)"
            } else {
                "record (R)"
            };
            if ui.button(rec).clicked() {
                self.press("R");
            }
        });
        if let Some(job) = &self.job {
            let (fraction, seconds) = job.progress();
            ui.add(egui::ProgressBar::new(fraction).text(format!(
                "{}: reference {:.0}% ({seconds:.1} s)",
                job.what,
                fraction * 100.0
            )));
        }
        if let Some(note) = &self.note {
            ui.label(note);
        }
        ui.label(format!("writes to {}", self.options.out.display()));
        ui.separator();
        self.timing_section(ui);
    }

    fn camera_section(&mut self, ui: &mut egui::Ui) {
        ui.label(
            "camera: W A S D Q E fly, drag the image to turn, wheel for speed, Home: the scene's",
        );
        let Some(shown) = &self.session.shown else {
            return;
        };
        let speed = self
            .fly
            .map_or(String::new(), |f| format!(", {:.2} units/s", f.speed));
        let whose = if shown.setup.camera.is_some() {
            "flown"
        } else {
            "the scene's own"
        };
        ui.label(format!(
            "{whose} camera{speed}; the same frame from the command line:"
        ));
        let command = self.render_command(&shown.setup);
        ui.add(
            egui::TextEdit::multiline(&mut command.as_str())
                .desired_rows(3)
                .font(egui::TextStyle::Monospace),
        );
        if ui.button("copy as render command (C)").clicked() {
            self.press("C");
        }
    }

    /// Each pass's time over the last frames, stacked.
    fn timing_section(&mut self, ui: &mut egui::Ui) {
        let Some(last) = self.session.history.back() else {
            return;
        };
        let source = if last.gpu_timestamps {
            "GPU timestamps"
        } else {
            "wall clock, each pass submitted alone"
        };
        ui.label(format!(
            "time per pass ({source}): {:.2} ms",
            last.total_ms()
        ));
        let mut names: Vec<&str> = Vec::new();
        for t in &self.session.history {
            for (n, _) in &t.passes {
                if !names.contains(&n.as_str()) {
                    names.push(n);
                }
            }
        }
        let colour = |i: usize| {
            let hue = (i as f32 * 0.618_034).fract();
            egui::Color32::from(egui::ecolor::Hsva::new(hue, 0.6, 0.9, 1.0))
        };
        let (rect, _) =
            ui.allocate_exact_size(egui::vec2(PANEL_WIDTH - 20.0, 90.0), egui::Sense::hover());
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 0.0, egui::Color32::from_gray(25));
        let most = self
            .session
            .history
            .iter()
            .map(|t| t.total_ms())
            .fold(1e-3, f64::max);
        let bar = rect.width() / super::session::HISTORY as f32;
        for (i, t) in self.session.history.iter().enumerate() {
            let x = rect.left() + i as f32 * bar;
            let mut y = rect.bottom();
            for (n, ms) in &t.passes {
                let h = (*ms / most) as f32 * rect.height();
                let k = names.iter().position(|m| m == n).unwrap_or(0);
                painter.rect_filled(
                    egui::Rect::from_min_max(egui::pos2(x, y - h), egui::pos2(x + bar.max(1.0), y)),
                    0.0,
                    colour(k),
                );
                y -= h;
            }
        }
        painter.text(
            rect.left_top(),
            egui::Align2::LEFT_TOP,
            format!("{most:.1} ms"),
            egui::FontId::monospace(10.0),
            egui::Color32::WHITE,
        );
        for (n, ms) in &last.passes {
            let k = names.iter().position(|m| m == n).unwrap_or(0);
            ui.colored_label(colour(k), format!("{n}: {ms:.2} ms"));
        }
    }

    fn counter_section(&mut self, ui: &mut egui::Ui) {
        ui.checkbox(
            &mut self.session.counters,
            "count light evaluations (an instrumented frame each)",
        );
        let Some(stats) = self.session.shown.as_ref().and_then(|s| s.stats.as_ref()) else {
            return;
        };
        ui.label(format!(
            "evaluations {}, useful {}, dropped {}",
            stats.light_evals, stats.useful_light_evals, stats.dropped_lights
        ));
        if let Some(r) = stats.shadow_rays {
            let nodes = r.nodes_per_ray().map_or("-".into(), |n| format!("{n:.1}"));
            ui.label(format!(
                "shadow rays {}, blocked {}, BVH nodes per ray {nodes}",
                r.traced, r.blocked
            ));
        }
    }
}

/// The shadows the panel offers: none, exact, each estimator at one ray, and `current`.
fn shadow_choices(current: Shadows) -> Vec<Shadows> {
    let sampled = |method| {
        Shadows::Sampled(ShadowSampling {
            method,
            ..ShadowSampling::default()
        })
    };
    let mut out = vec![
        Shadows::None,
        Shadows::Exact,
        sampled(ShadowSampler::Importance),
        sampled(ShadowSampler::Ratio),
    ];
    if !out.contains(&current) {
        out.push(current);
    }
    out
}

/// The flight a held key gives: forward, right, up.
fn key_thrust(key: &str) -> (f32, f32, f32) {
    match key {
        "W" => (1.0, 0.0, 0.0),
        "S" => (-1.0, 0.0, 0.0),
        "D" => (0.0, 1.0, 0.0),
        "A" => (0.0, -1.0, 0.0),
        "E" => (0.0, 0.0, 1.0),
        "Q" => (0.0, 0.0, -1.0),
        _ => (0.0, 0.0, 0.0),
    }
}

/// What a script step waits for.
enum Waiting {
    Frames(u32),
    /// A batch of changes on disk handled after this count, and drawn.
    Reload(u64),
    Job,
    Recording,
    WindowShot(ShotSlot),
}

impl Waiting {
    /// What has not come, in words.
    fn what(&self) -> &'static str {
        match self {
            Waiting::Frames(_) => "the window drew no more frames (is it hidden or minimised?)",
            Waiting::Reload(_) => {
                "the file watcher reported no change to the edited file, or the reload is still composing (a file system without change events, or a very slow composition)"
            }
            Waiting::Job => "the screenshot or error measurement has not finished",
            Waiting::Recording => {
                "the recording has not taken all its frames (the window drew too few)"
            }
            Waiting::WindowShot(_) => "the window has not been drawn for its shot (is it hidden?)",
        }
    }
}

/// A script being played.
struct Player {
    steps: Vec<Step>,
    next: usize,
    waiting: Option<(Waiting, Instant)>,
    /// Keys a `Key` step holds, and frames left.
    held: Vec<(String, u32)>,
    /// The output folder given (`Out` steps write below it).
    base: PathBuf,
}

impl Player {
    fn new(steps: Vec<Step>, base: PathBuf) -> Player {
        Player {
            steps,
            next: 0,
            waiting: None,
            held: Vec::new(),
            base,
        }
    }

    /// Run steps until one waits: `Ok(true)` when the script is done.
    fn tick(&mut self, app: &mut App) -> Result<bool, String> {
        for (_, left) in &mut self.held {
            *left = left.saturating_sub(1);
        }
        self.held.retain(|(_, left)| *left > 0);
        loop {
            if let Some((waiting, since)) = &mut self.waiting {
                let done = match waiting {
                    Waiting::Frames(n) => {
                        *n = n.saturating_sub(1);
                        *n == 0
                    }
                    Waiting::Reload(at) => app.reloads > *at && !app.session.dirty,
                    Waiting::Job => {
                        app.take_job();
                        if let Some(why) = app.job_failure.take() {
                            return Err(format!("step {}: {why}", self.next));
                        }
                        app.job.is_none()
                    }
                    Waiting::Recording => app.recording.is_none(),
                    Waiting::WindowShot(slot) => match slot.lock().expect("not poisoned").take() {
                        Some(Ok(())) => true,
                        Some(Err(e)) => return Err(format!("step {}: {e}", self.next)),
                        None => false,
                    },
                };
                if !done {
                    if since.elapsed().as_secs_f64() > WAIT_LIMIT_S {
                        return Err(format!(
                            "step {} ({:?}) still waits after {WAIT_LIMIT_S} s: {}",
                            self.next,
                            self.steps[self.next - 1],
                            waiting.what()
                        ));
                    }
                    return Ok(false);
                }
                self.waiting = None;
            }
            let Some(step) = self.steps.get(self.next).cloned() else {
                return Ok(true);
            };
            self.next += 1;
            if let Step::Out(folder) = &step {
                app.options.out = crate::files::inside(&self.base, folder, "Out folder")
                    .map_err(|e| format!("step {}: {e}", self.next))?;
                continue;
            }
            let waiting = run_step(step, app, &mut self.held)
                .map_err(|e| format!("step {}: {e}", self.next))?;
            if let Some(w) = waiting {
                // What a step waits for is looked at from the next frame on.
                self.waiting = Some((w, Instant::now()));
                return Ok(false);
            }
        }
    }
}

/// Do one step; what it waits for, if anything.
fn run_step(
    step: Step,
    app: &mut App,
    held: &mut Vec<(String, u32)>,
) -> Result<Option<Waiting>, String> {
    Ok(match step {
        Step::Wait { frames } => (frames > 0).then_some(Waiting::Frames(frames)),
        Step::Key { key, frames } => {
            if key_thrust(&key) != (0.0, 0.0, 0.0) {
                held.push((key, frames.max(1)));
                Some(Waiting::Frames(frames.max(1)))
            } else if ["Space", "Period", "Home", "P", "R", "C"].contains(&key.as_str()) {
                app.press(&key);
                None
            } else {
                return Err(format!(
                    "`{key}` is not a key the viewer knows: W, A, S, D, Q, E, Space, Period, Home, P, R, C"
                ));
            }
        }
        Step::Drag { dx, dy } => {
            app.fly_by(|fly| fly.turn(dx, dy));
            None
        }
        Step::Wheel { steps } => {
            app.fly_by(|fly| fly.wheel(steps as f32));
            None
        }
        Step::Set(change) => {
            set(app, change)?;
            None
        }
        Step::Edit {
            file,
            find,
            replace,
        } => {
            if let Some(why) = app.watch.unwatched(&file) {
                return Err(format!("Edit `{}`: {why}", file.display()));
            }
            let text = crate::files::read_text(&file, crate::files::read::VARIANT)
                .map_err(|e| format!("{}: {}", file.display(), e.why))?;
            if !text.contains(&find) {
                return Err(format!("{}: has no `{find}` to replace", file.display()));
            }
            let edited = text.replacen(&find, &replace, 1);
            // The file would be written as it was: no reload would come to wait for.
            if edited == text {
                return Err(format!(
                    "Edit `{}`: replacing `{find}` with `{replace}` changes nothing, so no reload would follow",
                    file.display()
                ));
            }
            crate::files::write_file(&file, edited.as_bytes())?;
            Some(Waiting::Reload(app.reloads))
        }
        Step::Screenshot => {
            app.start_screenshot()?;
            Some(Waiting::Job)
        }
        Step::MeasureError => {
            app.start_error()?;
            Some(Waiting::Job)
        }
        Step::Record { frames } => {
            app.start_recording(Some(frames.max(1)));
            Some(Waiting::Recording)
        }
        Step::State(file) => {
            let text =
                serde_json::to_string_pretty(&app.state_json()).map_err(|e| e.to_string())?;
            let path = output_path(&app.options.out, &file, "State")?;
            crate::files::write_file(&path, text.as_bytes())?;
            None
        }
        Step::Out(_) => None,
        Step::WindowShot(file) => {
            let path = output_path(&app.options.out, &file, "WindowShot")?;
            Some(Waiting::WindowShot(app.window_shot(path)))
        }
    })
}

/// Where a script's step writes `file`: inside the output folder (`files::inside`), its
/// folders made.
fn output_path(out: &Path, file: &Path, step: &str) -> Result<PathBuf, String> {
    let path = crate::files::inside(out, file, &format!("{step} path"))?;
    if let Some(parent) = path.parent() {
        crate::files::write::create_folder(parent)?;
    }
    Ok(path)
}

/// A variant file's name: its stem.
fn variant_name(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The variant a script names: one the viewer offers by its name (a file given by path
/// too), else a path or a name in `variants/`.
fn offered(variants: &[PathBuf], name: &str) -> Result<PathBuf, String> {
    match variants.iter().find(|v| variant_name(v) == name) {
        Some(v) => Ok(v.clone()),
        None => crate::variant::locate(name),
    }
}

/// A panel change from a script.
fn set(app: &mut App, change: Change) -> Result<(), String> {
    let mut setup = app.session.setup.clone();
    match change {
        Change::Variant(v) => {
            setup = app
                .session
                .setup_for_variant(offered(&app.options.variants, &v)?)?
        }
        Change::Scene(s) => {
            setup.params = crate::scene::defaults(&s).map_err(|e| e.to_string())?;
            setup.scene = s;
            setup.camera = None;
            app.fly = None;
        }
        Change::Lights(n) => setup.params.lights = n,
        Change::Radius(a, b) => setup.params.radius_range = (a, b),
        Change::Spots(f) => setup.params.spots = f,
        Change::Seed(s) => setup.params.seed = s,
        Change::Time(t) => setup.params.time = t,
        Change::Play(on) => app.playing = on,
        Change::DebugView(name) => {
            setup.debug_view = if name == "off" {
                DebugView::Off
            } else {
                DebugView::named(&name).ok_or_else(|| format!("`{name}` is not a debug view"))?
            }
        }
        Change::Samples(n) => setup.samples = n,
        Change::Camera(c) if c == "scene" => {
            app.scene_camera();
            return Ok(());
        }
        Change::Camera(c) => {
            let pose = CameraPose::parse(&c)?;
            setup.camera = Some(pose);
            app.fly = None;
        }
        Change::Counters(on) => app.session.counters = on,
    }
    app.session.change(setup);
    Ok(())
}
