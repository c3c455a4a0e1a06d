//! Rendering of an analysis: the text report and the SVG plot (numbers from the engine).

use wiical::render;
use wiical_analysis::{analyze, AnalyzeOptions};
use wiical_sim::{simulate, Device, EffectSpec, SimConfig, SimEffect};

#[test]
fn text_report_and_plot_render() {
    let s = simulate(&SimConfig {
        effects: vec![EffectSpec::new(SimEffect::Cubic, Some(30.0))],
        seed: 61,
        device: Device::Wiimote,
        ..Default::default()
    })
    .unwrap();
    let r = analyze(&s.recording, &AnalyzeOptions::default()).unwrap();
    let text = render::analyze::render_text(&r, "sim.csv");
    assert!(text.contains("cubic") && text.contains("noise floor"));
    let svg = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-analyze-{}.svg", std::process::id()));
    render::plot::write_plot(&r, &svg).unwrap();
    let body = std::fs::read_to_string(&svg).unwrap();
    assert!(body.starts_with("<svg") && body.contains("circle"));
    let _ = std::fs::remove_file(svg);
}
