use agvsim::record::Recording;
use agvsim::replay::{replay_with, Engine};
use agvsim::scene::Scene;
use agvsim::sim::reduced::Stepping;
use std::path::Path;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let rec = Recording::load(Path::new(&a[2])).unwrap();
    let s = Scene::load(Path::new(&a[1]), &[]).unwrap();
    println!("{:?} dt {}", Stepping::of(&s).unwrap(), s.sim.dt_s);
    let held = Engine::reduced_held_at(&s).unwrap();
    let t = std::time::Instant::now();
    for _ in 0..20 { replay_with(&s, &rec, held).unwrap(); }
    println!("reduced {:.1} ms per replay, {} rows", t.elapsed().as_secs_f64() * 50.0, rec.t_s.len());
    let t = std::time::Instant::now();
    replay_with(&s, &rec, Engine::Simulator).unwrap();
    println!("simulator {:.1} ms per replay", t.elapsed().as_secs_f64() * 1000.0);
}
