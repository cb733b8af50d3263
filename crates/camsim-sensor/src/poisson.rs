//! Exact Poisson sampling for photon shot noise, fast for a mean that changes at every pixel
//! (rand_distr 0.4's sampler costs ~0.5 us per new mean in the 12..100 range; these cost tens of ns).
//!
//! - mean < 10: inversion by sequential search of the CDF from 0 (Devroye 1986, X.3.3), one uniform,
//!   about mean + 1 steps;
//! - mean >= 10: transformed rejection with squeeze, PTRS (W. Hörmann 1993, "The transformed
//!   rejection method for generating Poisson random variables", Insurance: Math. Econ. 12, 39-45),
//!   about 1.1 iterations of two uniforms.

use rand::RngCore;

/// Uniform on [0, 1) with 53 random bits.
#[inline]
fn uniform<G: RngCore>(rng: &mut G) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
}

/// ln(k!) : exact table below 16, Stirling's series above (error < 1e-12 there).
fn ln_factorial(k: f64) -> f64 {
    const TABLE: [f64; 16] = [
        0.0,
        0.0,
        std::f64::consts::LN_2,
        1.791_759_469_228_055,
        3.178_053_830_347_945_7,
        4.787_491_742_782_046,
        6.579_251_212_010_101,
        8.525_161_361_065_415,
        10.604_602_902_745_25,
        12.801_827_480_081_469,
        15.104_412_573_075_516,
        17.502_307_845_873_887,
        19.987_214_495_661_885,
        22.552_163_853_123_42,
        25.191_221_182_738_68,
        27.899_271_383_840_894,
    ];
    if k < 16.0 {
        return TABLE[k as usize];
    }
    // ln Gamma(n + 1) = (n + 1/2) ln n - n + ln(2 pi)/2 + 1/(12 n) - 1/(360 n^3) + 1/(1260 n^5)
    let n = k;
    let inv = 1.0 / n;
    let inv2 = inv * inv;
    (n + 0.5) * n.ln() - n
        + 0.918_938_533_204_672_7
        + inv * (1.0 / 12.0 - inv2 * (1.0 / 360.0 - inv2 / 1260.0))
}

/// One Poisson deviate of mean `mean` (>= 0, finite), as f64.
#[inline]
pub(crate) fn sample<G: RngCore>(rng: &mut G, mean: f64) -> f64 {
    if !(mean > 0.0 && mean.is_finite()) {
        return 0.0; // also NaN: never loop on a bad mean
    }
    if mean < 10.0 {
        // Inversion: smallest k with CDF(k) > u, p_k = p_{k-1} mean / k.
        let mut p = (-mean).exp();
        let mut cdf = p;
        let u = uniform(rng);
        let mut k = 0.0;
        while u >= cdf {
            k += 1.0;
            p *= mean / k;
            cdf += p;
            if p < 1e-300 && k > mean {
                break; // u within round-off of 1
            }
        }
        return k;
    }
    ptrs(rng, mean)
}

#[cold]
fn ptrs<G: RngCore>(rng: &mut G, mean: f64) -> f64 {
    // Hörmann 1993, algorithm PTRS, constants as published.
    let slam = mean.sqrt();
    let loglam = mean.ln();
    let b = 0.931 + 2.53 * slam;
    let a = -0.059 + 0.024_83 * b;
    let inv_alpha = 1.1239 + 1.1328 / (b - 3.4);
    let v_r = 0.9277 - 3.6224 / (b - 2.0);
    loop {
        let u = uniform(rng) - 0.5;
        let v = uniform(rng);
        let us = 0.5 - u.abs();
        let k = ((2.0 * a / us + b) * u + mean + 0.43).floor();
        if us >= 0.07 && v <= v_r {
            return k;
        }
        if k < 0.0 || (us < 0.013 && v > us) {
            continue;
        }
        if (v * inv_alpha / (a / (us * us) + b)).ln() <= -mean + k * loglam - ln_factorial(k) {
            return k;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pmf(k: usize, mean: f64) -> f64 {
        (-mean + k as f64 * mean.ln() - ln_factorial(k as f64)).exp()
    }

    #[test]
    fn ln_factorial_matches_the_product() {
        let mut lf = 0.0f64;
        for k in 1..60 {
            lf += (k as f64).ln();
            assert!(
                (ln_factorial(k as f64) - lf).abs() < 1e-10 * lf.max(1.0),
                "{k}"
            );
        }
    }

    /// Mean, variance and the probability of every value with non-negligible mass against the
    /// Poisson pmf, for means on both sides of the method switch (binomial standard errors, 5 SE).
    #[test]
    fn samples_follow_the_poisson_distribution() {
        let n = 400_000usize;
        for (j, mean) in [0.3f64, 2.5, 9.99, 10.0, 17.3, 55.0, 99.9]
            .into_iter()
            .enumerate()
        {
            let mut rng = camsim_core::rng::keyed(3, 98, 0, j as u64);
            let kmax = (mean + 12.0 * mean.sqrt() + 20.0) as usize;
            let mut counts = vec![0usize; kmax + 1];
            let (mut s1, mut s2) = (0.0, 0.0);
            for _ in 0..n {
                let k = sample(&mut rng, mean);
                assert!(k >= 0.0 && k.fract() == 0.0);
                s1 += k;
                s2 += k * k;
                counts[(k as usize).min(kmax)] += 1;
            }
            let nf = n as f64;
            let m = s1 / nf;
            let v = s2 / nf - m * m;
            assert!(
                (m - mean).abs() < 5.0 * (mean / nf).sqrt(),
                "mean {mean}: {m}"
            );
            // Var of the sample variance of a Poisson: (mu4 - sigma^4)/n with mu4 = mean (1 + 3 mean).
            let se_v = ((mean * (1.0 + 3.0 * mean) - mean * mean) / nf).sqrt();
            assert!(
                (v - mean).abs() < 5.0 * se_v,
                "variance at mean {mean}: {v}"
            );
            for (k, c) in counts.iter().enumerate().take(kmax) {
                let p = pmf(k, mean);
                let se = (nf * p * (1.0 - p)).sqrt();
                assert!(
                    (*c as f64 - nf * p).abs() < 5.0 * se + 2.0,
                    "mean {mean}, k = {k}: {c} vs {}",
                    nf * p
                );
            }
        }
    }
}
