use camsim_optics::{diffraction_mtf, Wavefront};
fn main() {
    let wf = Wavefront::diffraction_limited(4.38e-3, 2.8).unwrap();
    let m = wf.mtf(550.0).unwrap();
    for (i, f) in m.freq_cyc_per_mm.iter().enumerate().step_by(8) {
        let w = diffraction_mtf(*f, 550.0, 2.8);
        println!("{:.3} {:.5} {:.5} {:+.5}", f * 550e-6 * 2.8, m.mtf_x[i], w, m.mtf_x[i] - w);
    }
}
