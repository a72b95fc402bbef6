//! When the coarse base's build can stop ([`CoarseBase::new_until`]): the seconds at which
//! each of its stop checks comes and the whole build's, so that the longest wait after a
//! cancel (the largest gap) can be read off. Default base settings.
//!
//!     cargo run --release -p solver --example cancel_points -- MESH

use std::sync::Mutex;
use std::time::Instant;

use solver::BaseConfig;
use solver::deform::coarse::base::CoarseBase;

fn main() -> Result<(), String> {
    let path = std::env::args().nth(1).ok_or("usage: cancel_points MESH")?;
    let mesh = solver::io::load_mesh(std::path::Path::new(&path)).map_err(|e| e.to_string())?.mesh;
    let t = Instant::now();
    let checks = Mutex::new(Vec::new());
    let stop = || {
        checks.lock().map(|mut c| c.push(t.elapsed().as_secs_f64())).ok();
        false
    };
    CoarseBase::new_until(&mesh, &BaseConfig::default(), &stop).map_err(|e| e.to_string())?;
    let total = t.elapsed().as_secs_f64();
    let checks = checks.into_inner().map_err(|e| e.to_string())?;
    let at: Vec<String> = checks.iter().map(|s| format!("{s:.2}")).collect();
    let gaps =
        checks.iter().chain([&total]).scan(0.0, |last, &s| Some(s - std::mem::replace(last, s)));
    let longest = gaps.fold(0.0, f64::max);
    println!(
        "{} vertices: stop checks at [{}] s, built in {total:.2} s; longest wait {longest:.2} s",
        mesh.n_vertices(),
        at.join(", ")
    );
    Ok(())
}
