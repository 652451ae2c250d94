//! The statistics behind every published number: medians, seeded bootstrap intervals (of a
//! median and of a ratio of medians, paired or not), MAD outliers and the Mann–Whitney U test.
//! Distribution-free throughout: run times are skewed (a run can only be slowed down) and
//! have outliers, so means and t intervals describe them poorly.

/// Resamples per bootstrap interval: the 2.5 % and 97.5 % percentiles then rest on 50 values
/// each, which moves the bounds by well under the ±2 % targets on 5–30 samples.
pub const RESAMPLES: usize = 2000;

/// The median of `v` (the mean of the middle two for an even count; NaN when empty).
pub fn median(v: &[f64]) -> f64 {
    let mut s: Vec<f64> = v.to_vec();
    median_in_place(&mut s)
}

fn median_in_place(s: &mut [f64]) -> f64 {
    let n = s.len();
    if n == 0 {
        return f64::NAN;
    }
    let (_, hi, _) = s.select_nth_unstable_by(n / 2, f64::total_cmp);
    let hi = *hi;
    if n % 2 == 1 {
        return hi;
    }
    let lo = s[..n / 2].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    0.5 * (lo + hi)
}

/// Sample standard deviation (0 for fewer than two values).
pub fn std_dev(v: &[f64]) -> f64 {
    let n = v.len();
    if n < 2 {
        return 0.0;
    }
    let mean = v.iter().sum::<f64>() / n as f64;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
}

/// Values whose modified z-score 0.6745·|x − median| / MAD exceeds 3.5 (Iglewicz and Hoaglin's
/// rule); none when the MAD is 0.
pub fn mad_outliers(v: &[f64]) -> usize {
    let m = median(v);
    let dev: Vec<f64> = v.iter().map(|x| (x - m).abs()).collect();
    let mad = median(&dev);
    if mad.is_nan() || mad <= 0.0 {
        return 0;
    }
    dev.iter().filter(|d| 0.6745 * **d / mad > 3.5).count()
}

/// SplitMix64: a seeded stream for resampling (the same seed gives the same interval).
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64 * n as f64) as usize % n.max(1)
    }
}

/// A seeded Fisher–Yates shuffle.
pub fn shuffle<T>(v: &mut [T], seed: u64) {
    let mut r = SplitMix(seed);
    for i in (1..v.len()).rev() {
        v.swap(i, r.below(i + 1));
    }
}

/// The 2.5 % and 97.5 % percentiles of `stats`.
fn percentile_interval(mut stats: Vec<f64>) -> (f64, f64) {
    stats.retain(|x| x.is_finite());
    if stats.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    stats.sort_by(f64::total_cmp);
    let at = |q: f64| stats[((q * (stats.len() - 1) as f64).round() as usize).min(stats.len() - 1)];
    (at(0.025), at(0.975))
}

/// Seeded percentile-bootstrap 95 % interval of the median of `v`; `(x, x)` for one value.
pub fn median_ci(v: &[f64], seed: u64) -> (f64, f64) {
    if v.len() < 2 {
        let m = median(v);
        return (m, m);
    }
    let mut r = SplitMix(seed);
    let mut buf = vec![0.0; v.len()];
    let stats = (0..RESAMPLES)
        .map(|_| {
            for b in buf.iter_mut() {
                *b = v[r.below(v.len())];
            }
            median_in_place(&mut buf)
        })
        .collect();
    percentile_interval(stats)
}

/// Half the width of [`median_ci`] over the median: the relative precision of a median.
pub fn relative_half_width(v: &[f64], seed: u64) -> f64 {
    let (lo, hi) = median_ci(v, seed);
    0.5 * (hi - lo) / median(v)
}

/// A ratio of medians with its 95 % bootstrap interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ratio {
    /// median(numerator) / median(denominator).
    pub value: f64,
    /// 2.5 % percentile of the resampled ratios.
    pub lo: f64,
    /// 97.5 % percentile.
    pub hi: f64,
    /// Samples (pairs, or the smaller side when unpaired) it rests on.
    pub n: usize,
}

/// median(num) / median(den) over pairs measured in the same round (index i of both slices),
/// its interval from resampling whole pairs, so drift common to a pair cancels.
pub fn paired_ratio(num: &[f64], den: &[f64], seed: u64) -> Ratio {
    let n = num.len().min(den.len());
    let value = median(&num[..n]) / median(&den[..n]);
    if n < 2 {
        return Ratio {
            value,
            lo: value,
            hi: value,
            n,
        };
    }
    let mut r = SplitMix(seed);
    let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
    let stats = (0..RESAMPLES)
        .map(|_| {
            for k in 0..n {
                let i = r.below(n);
                a[k] = num[i];
                b[k] = den[i];
            }
            median_in_place(&mut a) / median_in_place(&mut b)
        })
        .collect();
    let (lo, hi) = percentile_interval(stats);
    Ratio { value, lo, hi, n }
}

/// median(num) / median(den) of two independent samples, each resampled on its own.
pub fn unpaired_ratio(num: &[f64], den: &[f64], seed: u64) -> Ratio {
    let value = median(num) / median(den);
    let n = num.len().min(den.len());
    if num.len() < 2 || den.len() < 2 {
        return Ratio {
            value,
            lo: value,
            hi: value,
            n,
        };
    }
    let mut r = SplitMix(seed);
    let (mut a, mut b) = (vec![0.0; num.len()], vec![0.0; den.len()]);
    let stats = (0..RESAMPLES)
        .map(|_| {
            for x in a.iter_mut() {
                *x = num[r.below(num.len())];
            }
            for x in b.iter_mut() {
                *x = den[r.below(den.len())];
            }
            median_in_place(&mut a) / median_in_place(&mut b)
        })
        .collect();
    let (lo, hi) = percentile_interval(stats);
    Ratio { value, lo, hi, n }
}

/// The change of a paired ratio between two runs: (median(num_b)/median(den_b)) /
/// (median(num_a)/median(den_a)), each run's pairs resampled on their own.
pub fn paired_ratio_change(a: (&[f64], &[f64]), b: (&[f64], &[f64]), seed: u64) -> Ratio {
    let ra = median(a.0) / median(a.1);
    let rb = median(b.0) / median(b.1);
    let value = rb / ra;
    let (na, nb) = (a.0.len().min(a.1.len()), b.0.len().min(b.1.len()));
    if na < 2 || nb < 2 {
        return Ratio {
            value,
            lo: value,
            hi: value,
            n: na.min(nb),
        };
    }
    let mut r = SplitMix(seed);
    let resampled = |(num, den): (&[f64], &[f64]), n: usize, r: &mut SplitMix| {
        let (mut x, mut y) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..n {
            let i = r.below(n);
            x[k] = num[i];
            y[k] = den[i];
        }
        median_in_place(&mut x) / median_in_place(&mut y)
    };
    let stats = (0..RESAMPLES)
        .map(|_| {
            let ra = resampled(a, na, &mut r);
            resampled(b, nb, &mut r) / ra
        })
        .collect();
    let (lo, hi) = percentile_interval(stats);
    Ratio {
        value,
        lo,
        hi,
        n: na.min(nb),
    }
}

/// Two-sided p-value of the Mann–Whitney U test that `a` and `b` come from one distribution,
/// by the normal approximation with tie and continuity corrections (1 when either is empty or
/// every value is tied).
pub fn mann_whitney_p(a: &[f64], b: &[f64]) -> f64 {
    let z = mann_whitney_z(a, b);
    if z == 0.0 {
        // No evidence at all; exactly 1 (Φ's approximation gives 1 − 1e-9 at 0).
        return 1.0;
    }
    (2.0 * (1.0 - normal_cdf(z.abs()))).clamp(0.0, 1.0)
}

/// The Mann–Whitney U statistic of `a` against `b` as a signed, continuity-corrected normal
/// score: positive when `b` tends to be larger than `a` (0 when either is empty or every value
/// is tied). One-sided tests read its sign ([`super::verdict`]).
pub fn mann_whitney_z(a: &[f64], b: &[f64]) -> f64 {
    let (n1, n2) = (a.len() as f64, b.len() as f64);
    if a.is_empty() || b.is_empty() {
        return 0.0;
    }
    let mut all: Vec<(f64, bool)> = a
        .iter()
        .map(|&x| (x, true))
        .chain(b.iter().map(|&x| (x, false)))
        .collect();
    all.sort_by(|x, y| x.0.total_cmp(&y.0));
    let n = all.len();
    let (mut rank_a, mut ties) = (0.0, 0.0);
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && all[j + 1].0 == all[i].0 {
            j += 1;
        }
        let rank = (i + j) as f64 / 2.0 + 1.0;
        let t = (j - i + 1) as f64;
        ties += t * t * t - t;
        rank_a += rank * all[i..=j].iter().filter(|x| x.1).count() as f64;
        i = j + 1;
    }
    let u = rank_a - n1 * (n1 + 1.0) / 2.0;
    let mean = n1 * n2 / 2.0;
    let nn = n1 + n2;
    let var = n1 * n2 / 12.0 * ((nn + 1.0) - ties / (nn * (nn - 1.0)));
    if var.is_nan() || var <= 0.0 {
        return 0.0;
    }
    // U counts the pairs where a is the larger: below its mean, b tends to be larger.
    let d = mean - u;
    d.signum() * (d.abs() - 0.5).max(0.0) / var.sqrt()
}

/// Φ(z), by Abramowitz and Stegun 7.1.26 (error < 1.5·10⁻⁷).
pub fn normal_cdf(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-x * x).exp();
    if z >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_and_spread() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
        assert!((std_dev(&[1.0, 2.0, 3.0]) - 1.0).abs() < 1e-12);
        assert_eq!(mad_outliers(&[1.0, 1.01, 0.99, 1.02, 0.98, 5.0]), 1);
        assert_eq!(mad_outliers(&[1.0, 1.01, 0.99, 1.02, 0.98]), 0);
    }

    #[test]
    fn bootstrap_intervals_cover_and_are_seeded() {
        let v: Vec<f64> = (0..21).map(|i| 1.0 + 0.01 * (i as f64 - 10.0)).collect();
        let (lo, hi) = median_ci(&v, 7);
        assert!(lo < 1.0 && hi > 1.0 && lo >= 0.9 && hi <= 1.1, "{lo} {hi}");
        assert_eq!(median_ci(&v, 7), (lo, hi));
        assert_eq!(median_ci(&[2.0], 7), (2.0, 2.0));
        // Paired: a common drift cancels, so the ratio is exact and its interval a point.
        let den: Vec<f64> = (0..10).map(|i| 1.0 + 0.1 * i as f64).collect();
        let num: Vec<f64> = den.iter().map(|x| 2.0 * x).collect();
        let r = paired_ratio(&num, &den, 3);
        assert!(
            (r.value - 2.0).abs() < 1e-12
                && (r.lo - 2.0).abs() < 1e-12
                && (r.hi - 2.0).abs() < 1e-12,
            "{r:?}"
        );
        // Unpaired, the same drift widens the interval around the same ratio.
        let u = unpaired_ratio(&num, &den, 3);
        assert!(
            (u.value - 2.0).abs() < 1e-12 && u.lo < 1.9 && u.hi > 2.1,
            "{u:?}"
        );
    }

    #[test]
    fn mann_whitney_matches_known_values() {
        // Fully separated samples of 10 and 10: U = 0, z = (50 − 0.5) / √175 = 3.742,
        // two-sided p = 1.83·10⁻⁴.
        let a: Vec<f64> = (0..10).map(f64::from).collect();
        let b: Vec<f64> = (10..20).map(f64::from).collect();
        let p = mann_whitney_p(&a, &b);
        assert!((p - 1.83e-4).abs() < 0.05e-4, "{p}");
        // The same sample against itself: no evidence of a difference.
        assert!(mann_whitney_p(&a, &a) > 0.9);
        assert_eq!(mann_whitney_p(&[1.0; 4], &[1.0; 4]), 1.0);
        assert!((normal_cdf(1.96) - 0.975).abs() < 1e-4);
    }

    #[test]
    fn shuffles_are_seeded_permutations() {
        let mut a: Vec<u32> = (0..20).collect();
        let mut b = a.clone();
        shuffle(&mut a, 5);
        shuffle(&mut b, 5);
        assert_eq!(a, b);
        assert_ne!(a, (0..20).collect::<Vec<_>>());
        a.sort_unstable();
        assert_eq!(a, (0..20).collect::<Vec<_>>());
    }
}
