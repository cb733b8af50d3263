use realfft::RealFftPlanner;
use rustfft::num_complex::Complex32;
use rustfft::FftPlanner;
use std::time::Instant;
fn main() {
    let f = 512;
    let nc = f / 2 + 1;
    let mut rp = RealFftPlanner::<f32>::new();
    let r2c = rp.plan_fft_forward(f);
    let c2r = rp.plan_fft_inverse(f);
    let fwd = FftPlanner::<f32>::new().plan_fft_forward(f);
    let z = Complex32::new(0.0, 0.0);
    let mut row = vec![1.0f32; f];
    let mut spec = vec![z; nc];
    let mut sc = vec![z; r2c.get_scratch_len().max(c2r.get_scratch_len())];
    let n = 4000;
    let t = Instant::now();
    for _ in 0..n {
        r2c.process_with_scratch(&mut row, &mut spec, &mut sc).unwrap();
    }
    println!("r2c 512: {:.2} us", t.elapsed().as_secs_f64() / n as f64 * 1e6);
    let mut cols = vec![Complex32::new(1.0, 0.0); nc * f];
    let mut cs = vec![z; fwd.get_inplace_scratch_len()];
    let t = Instant::now();
    for _ in 0..10 {
        fwd.process_with_scratch(&mut cols, &mut cs);
    }
    println!("257 col fft 512: {:.2} ms", t.elapsed().as_secs_f64() / 10.0 * 1e3);
    let t = Instant::now();
    for _ in 0..n {
        spec[0].im = 0.0;
        spec[nc - 1].im = 0.0;
        c2r.process_with_scratch(&mut spec, &mut row, &mut sc).unwrap();
    }
    println!("c2r 512: {:.2} us", t.elapsed().as_secs_f64() / n as f64 * 1e6);
    println!("is_x86_feature_detected avx: {} fma: {}", is_x86_feature_detected!("avx"), is_x86_feature_detected!("fma"));
}
