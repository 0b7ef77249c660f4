//! The README's library example as a program: a mesh, a kd-tree, a tracer, then single rays,
//! a packet of the camera's pixels and a stream, with their hits printed.
//!
//! `cargo run --example trace [FILE.obj | builtin:NAME]` (default `builtin:icosphere`).

use kdbeam::scene::{load_obj, procedural};
use kdbeam::trace::Culling;
use kdbeam::{BuildParams, Camera, Hit, HitPacket, KdTree, Mesh, PacketShape, Ray, Tracer, Vec3};

fn main() -> Result<(), kdbeam::Error> {
    let name = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "builtin:icosphere".into());
    let mesh: Mesh = match name.strip_prefix("builtin:") {
        Some(builtin) => procedural::builtin(builtin)?,
        None => load_obj(&name)?,
    };
    let tree = KdTree::build(&mesh, &BuildParams::default())?;
    println!(
        "{name}: {} triangles; kd-tree {}",
        mesh.triangle_count(),
        tree.stats()
    );

    // The widest ISA this CPU runs (or KDBEAM_ISA), culling chosen per leaf.
    let tracer = Tracer::new(&tree).with_culling(Culling::AUTO);
    println!("tracer: {} ISA, culling {}", tracer.isa(), tracer.culling());

    // Single rays, from outside the box towards its centre along each axis.
    let bounds = tree.bounds();
    let centre = bounds.center();
    for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
        let origin = centre - axis * bounds.extent().max_element();
        let ray = Ray::new(origin, axis);
        print_hit(&format!("ray along {axis}"), &ray, &tracer.intersect(&ray));
        println!("  occluded: {}", tracer.occluded(&ray));
    }

    // One packet: the 8×8 pixel tile at the centre of the standard camera's 64×64 image.
    let camera = Camera::standard(&bounds, 64, 64);
    let packet = camera
        .tile_packets(PacketShape::P8x8)
        .into_iter()
        .nth(4 * 8 + 4)
        .expect("an 8×8 grid of tiles");
    let mut hits = HitPacket::default();
    tracer.intersect_packet(&packet, packet.full_mask(), &mut hits);
    let hit_count = (0..packet.len()).filter(|&j| hits.hit(j).is_hit()).count();
    println!("packet of {} rays: {hit_count} hit", packet.len());
    print_hit("  its first ray", &packet.ray(0), &hits.hit(0));

    // A stream: every primary ray of the camera, traced in packets on all cores.
    let rays = camera.rays();
    let mut stream_hits = vec![Hit::NONE; rays.len()];
    tracer.intersect_stream(&rays, &mut stream_hits)?;
    let hit_count = stream_hits.iter().filter(|h| h.is_hit()).count();
    println!("stream of {} rays: {hit_count} hit", rays.len());
    Ok(())
}

fn print_hit(what: &str, ray: &Ray, hit: &Hit) {
    if hit.is_hit() {
        println!(
            "{what}: triangle {} at t = {:.4} (u = {:.3}, v = {:.3}), point {}",
            hit.triangle,
            hit.t,
            hit.u,
            hit.v,
            ray.at(hit.t)
        );
    } else {
        println!("{what}: miss");
    }
}
