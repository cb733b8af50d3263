//! Small numerical helpers shared by the stages.

use rayon::prelude::*;

/// Values per block of [`fixed_order_sum`]: the blocking is fixed, so the sum's rounding never
/// depends on how many threads share the blocks.
const SUM_BLOCK: usize = 1 << 14;

/// The sum of `values` in f64, the same bits for any thread count: blocks of a fixed length
/// summed in parallel (each in eight f64 lanes, in order), then the block sums added pairwise in
/// a fixed tree ([`pairwise_sum`]). For every sum camsim writes to a file (means, luminance,
/// statistics): rayon's own `sum()` splits the work by thread count, and so rounds differently
/// with 1 or 2 threads.
pub fn fixed_order_sum(values: &[f32]) -> f64 {
    let blocks: Vec<f64> = values
        .par_chunks(SUM_BLOCK)
        .map(|block| {
            let mut lanes = [0f64; 8];
            let chunks = block.chunks_exact(8);
            let rest: f64 = chunks.remainder().iter().map(|x| *x as f64).sum();
            for c in chunks {
                for (l, x) in lanes.iter_mut().zip(c) {
                    *l += *x as f64;
                }
            }
            pairwise_sum(&lanes) + rest
        })
        .collect();
    pairwise_sum(&blocks)
}

/// Pairwise (cascade) summation in a fixed tree: halves summed recursively, so the rounding error
/// grows as O(log n) (Higham, "The accuracy of floating point summation", SIAM J. Sci. Comput.
/// 14 (1993)) and the result depends on the values and their order alone.
pub fn pairwise_sum(values: &[f64]) -> f64 {
    if values.len() <= 8 {
        return values.iter().sum();
    }
    let (a, b) = values.split_at(values.len() / 2);
    pairwise_sum(a) + pairwise_sum(b)
}

/// The normalized sinc, sin(pi x) / (pi x), with sinc(0) = 1: the transfer function of a box
/// (pixel aperture) of unit width at frequency x (Goodman, Introduction to Fourier Optics, 2.1).
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        1.0
    } else {
        let a = std::f64::consts::PI * x;
        a.sin() / a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 25 item 2: a written mean differed in its last digits between 1 and 2 workers.
    #[test]
    fn fixed_order_sum_has_the_same_bits_for_any_thread_count() {
        // Values spanning 12 decades, so the order of the additions shows in the rounding.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let v: Vec<f32> = (0..300_001)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let u = (x >> 11) as f64 / (1u64 << 53) as f64;
                (10f64.powf(12.0 * u - 6.0)) as f32
            })
            .collect();
        let in_pool = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| fixed_order_sum(&v))
        };
        let one = in_pool(1);
        for t in [2, 3, 4, 7] {
            assert_eq!(in_pool(t).to_bits(), one.to_bits(), "{t} threads");
        }
        let exact: f64 = v.iter().map(|x| *x as f64).sum();
        assert!((one - exact).abs() <= 1e-12 * exact, "{one} vs {exact}");
        assert_eq!(pairwise_sum(&[1.0, 2.0, 3.0]), 6.0);
        assert_eq!(fixed_order_sum(&[]), 0.0);
    }

    #[test]
    fn sinc_values() {
        assert_eq!(sinc(0.0), 1.0);
        for k in 1..5 {
            assert!(sinc(k as f64).abs() < 1e-15);
        }
        assert!((sinc(0.5) - 2.0 / std::f64::consts::PI).abs() < 1e-15);
    }
}
