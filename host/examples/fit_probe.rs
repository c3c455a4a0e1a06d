fn main() {
    let path = std::env::args().nth(1).unwrap();
    let rec = wiical::input::load(path.as_ref(), &Default::default()).unwrap();
    for th in [2.0, 3.0, 4.0, 6.0, 8.0, 10.0] {
        let mut o = wiical::fit_cmd::FitOptions::default();
        o.threshold_factor = th;
        match wiical::fit_cmd::run(&rec, &o) {
            Ok(r) => println!(
                "th {th}: windows {} rms_mg {:.4} max {:.3} it {} ident {:.2e} noise {:?}",
                r.static_windows,
                r.rms_mg,
                r.max_abs_mg,
                r.iterations,
                r.identifiability,
                r.noise_std
            ),
            Err(e) => println!("th {th}: {e:#}"),
        }
    }
}
