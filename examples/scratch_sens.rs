use agvsim::record::Recording;
use agvsim::replay::{replay_with, Engine};
use agvsim::scene::Scene;
use std::path::Path;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let rec = Recording::load(Path::new(&a[2])).unwrap();
    let key = &a[3];
    let base = Scene::load(Path::new(&a[1]), &[]).unwrap();
    let held = Engine::reduced_held_at(&base).unwrap();
    for engine in [Engine::Simulator, held] {
        let mut outs = vec![];
        for v in [&a[4], &a[5]] {
            let s = Scene::load(Path::new(&a[1]), &[format!("{key}={v}")]).unwrap();
            outs.push(replay_with(&s, &rec, engine).unwrap());
        }
        for (a, b) in outs[0].outputs.iter().zip(&outs[1].outputs) {
            let n = a.simulated.len() as f64;
            let rms = (a.simulated.iter().zip(&b.simulated).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n).sqrt();
            println!("{:<12} {:<24} sens rms {rms:.3e}", format!("{engine:?}").chars().take(12).collect::<String>(), a.name);
        }
    }
}
