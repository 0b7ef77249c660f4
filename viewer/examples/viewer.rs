//! A window onto a mesh traced by kdbeam every frame: orbit with the mouse (drag with the left
//! button, wheel to zoom) or the keys (arrows or WASD to turn, Q/E or +/− to zoom, Escape to
//! quit); shadows from a point light; Mrays/s, frame time and the culled share of ray–triangle
//! tests drawn in the corner.
//!
//! ```text
//! cargo run --release -p kdbeam-viewer --example viewer [SCENE] [--size WxH] [--threads N]
//! cargo run --release -p kdbeam-viewer --example viewer -- --frames 3 --size 128x128 --screenshot shot.png
//! ```
//!
//! SCENE is what `kdbeam render` takes: `builtin:NAME[:SIZE]`, a shared mesh's name (`bunny`,
//! from `KDBEAM_SCENES`) or an OBJ path; the default is `builtin:default`. With `--frames N`
//! the viewer renders N frames (turning a little each frame) and quits; `--screenshot FILE`
//! writes its last framebuffer, figures included, to a PNG and fails if the picture is blank
//! (a single colour).

use std::path::PathBuf;

use clap::Parser;
use kdbeam::{BuildParams, KdTree, Tracer};
use kdbeam_cli::render::{parse_size, Image};
use kdbeam_cli::scenes::load_scene;
use kdbeam_viewer::{distinct_colours, draw_text, render_frame, Orbit};
use minifb::{Key, MouseButton, MouseMode, Window, WindowOptions};

/// kdbeam's interactive viewer.
#[derive(Parser)]
struct Args {
    /// The mesh: builtin:NAME[:SIZE], a shared mesh's name or an OBJ path.
    #[arg(default_value = "builtin:default")]
    scene: String,
    /// Window size, WIDTHxHEIGHT.
    #[arg(long, default_value = "800x600", value_parser = parse_size)]
    size: (u32, u32),
    /// Render this many frames, then quit (default: until the window closes).
    #[arg(long)]
    frames: Option<u64>,
    /// Write the last framebuffer to this PNG when quitting.
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Threads (default: every core).
    #[arg(long)]
    threads: Option<usize>,
}

type AnyError = Box<dyn std::error::Error + Send + Sync>;

fn main() -> Result<(), AnyError> {
    let args = Args::parse();
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        pool = pool.num_threads(n);
    }
    pool.build()?.install(|| run(&args))
}

/// Radians a key turns the camera per frame.
const KEY_TURN: f32 = 0.05;
/// Radians per pixel of mouse drag.
const DRAG_TURN: f32 = 0.01;

fn run(args: &Args) -> Result<(), AnyError> {
    let mesh = load_scene(&args.scene)?;
    let tree = KdTree::build(&mesh, &BuildParams::for_mesh(&mesh))?;
    let tracer = Tracer::new(&tree);
    let (width, height) = (args.size.0 as usize, args.size.1 as usize);
    let mut window = Window::new(
        &format!("kdbeam: {} ({:?})", args.scene, tracer.isa()),
        width,
        height,
        WindowOptions::default(),
    )?;
    let mut orbit = Orbit::framing(&mesh.bounds());
    let mut pixels = Vec::new();
    let mut drag: Option<(f32, f32)> = None;
    let scale = (height / 120).max(1);
    let mut frames = 0u64;
    while window.is_open() && !window.is_key_down(Key::Escape) {
        steer(&window, &mut orbit, &mut drag);
        if args.frames.is_some() {
            orbit.turn(KEY_TURN, 0.0);
        }
        let camera = orbit.camera(width as u32, height as u32)?;
        let stats = render_frame(&tracer, &mesh, &camera, &mut pixels)?;
        draw_text(
            &mut pixels,
            width,
            (scale, scale),
            &stats.overlay(),
            scale,
            0x00ff_ff60,
        );
        window.update_with_buffer(&pixels, width, height)?;
        frames += 1;
        if args.frames.is_some_and(|n| frames >= n) {
            break;
        }
    }
    if let Some(path) = &args.screenshot {
        let mut image = Image::new(width as u32, height as u32);
        for (rgb, p) in image.rgb.chunks_exact_mut(3).zip(&pixels) {
            rgb.copy_from_slice(&p.to_be_bytes()[1..]);
        }
        image.write_png(path)?;
        let colours = distinct_colours(&pixels);
        println!(
            "{} frames; screenshot {} ({colours} colours)",
            frames,
            path.display()
        );
        if colours < 2 {
            return Err("the screenshot is blank".into());
        }
    }
    Ok(())
}

/// Turns and zooms `orbit` from the keys held and the mouse: a drag with the left button
/// turns, the wheel zooms.
fn steer(window: &Window, orbit: &mut Orbit, drag: &mut Option<(f32, f32)>) {
    let key = |keys: &[Key]| keys.iter().any(|&k| window.is_key_down(k));
    let mut yaw = 0.0;
    let mut pitch = 0.0;
    if key(&[Key::Left, Key::A]) {
        yaw -= KEY_TURN;
    }
    if key(&[Key::Right, Key::D]) {
        yaw += KEY_TURN;
    }
    if key(&[Key::Up, Key::W]) {
        pitch += KEY_TURN;
    }
    if key(&[Key::Down, Key::S]) {
        pitch -= KEY_TURN;
    }
    if key(&[Key::Q, Key::Equal, Key::NumPadPlus]) {
        orbit.zoom(0.95);
    }
    if key(&[Key::E, Key::Minus, Key::NumPadMinus]) {
        orbit.zoom(1.05);
    }
    let mouse = window.get_mouse_pos(MouseMode::Discard);
    if window.get_mouse_down(MouseButton::Left) {
        if let (Some((x0, y0)), Some((x, y))) = (*drag, mouse) {
            yaw += DRAG_TURN * (x - x0);
            pitch += DRAG_TURN * (y - y0);
        }
        *drag = mouse;
    } else {
        *drag = None;
    }
    if let Some((_, wheel)) = window.get_scroll_wheel() {
        orbit.zoom(0.9f32.powf(wheel.signum()));
    }
    orbit.turn(yaw, pitch);
}
