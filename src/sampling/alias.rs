//! Walker/Vose alias table: O(1) sampling of an index with probability proportional to a
//! weight (lights by power, triangles of an emitter by area).

/// An alias table over `n` weights.
#[derive(Clone, Debug)]
pub struct AliasTable {
    prob: Vec<f64>,
    alias: Vec<u32>,
    pdf: Vec<f64>,
}

impl AliasTable {
    /// Builds the table. Weights must be finite and non-negative with a positive, finite
    /// sum; otherwise the reason is returned.
    pub fn new(weights: &[f64]) -> Result<Self, &'static str> {
        let n = weights.len();
        if n == 0 {
            return Err("no weights");
        }
        if n > u32::MAX as usize {
            return Err("more than 2^32 weights");
        }
        if weights.iter().any(|w| !(*w >= 0.0 && w.is_finite())) {
            return Err("a weight is negative or not finite");
        }
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return Err("the weights' sum is zero or not finite");
        }
        let pdf: Vec<f64> = weights.iter().map(|w| w / total).collect();
        let mut scaled: Vec<f64> = pdf.iter().map(|p| p * n as f64).collect();
        let mut prob = vec![1.0; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            prob[s] = scaled[s];
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // Leftovers (rounding) keep probability 1 and alias to themselves.
        Ok(AliasTable { prob, alias, pdf })
    }

    /// Samples an index from a uniform number in [0, 1).
    #[inline]
    pub fn sample(&self, u: f64) -> usize {
        let n = self.prob.len();
        let x = u * n as f64;
        let i = (x as usize).min(n - 1);
        let frac = x - i as f64;
        if frac < self.prob[i] {
            i
        } else {
            self.alias[i] as usize
        }
    }

    /// The probability of index `i`.
    pub fn pdf(&self, i: usize) -> f64 {
        self.pdf[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::PhotonRng;

    #[test]
    fn frequencies_match_weights() {
        let w = [1.0, 0.0, 3.0, 6.0, 0.5];
        let t = AliasTable::new(&w).unwrap();
        let total: f64 = w.iter().sum();
        let n = 400_000;
        let mut count = [0usize; 5];
        let mut rng = PhotonRng::new(3, 0);
        for _ in 0..n {
            count[t.sample(rng.uniform())] += 1;
        }
        for i in 0..5 {
            let p = w[i] / total;
            let sd = (p * (1.0 - p) / n as f64).sqrt();
            let f = count[i] as f64 / n as f64;
            assert!((f - p).abs() <= 5.0 * sd + 1e-12, "index {i}: {f} vs {p}");
            assert!((t.pdf(i) - p).abs() < 1e-15);
        }
        assert_eq!(count[1], 0, "a zero weight must never be drawn");
    }

    #[test]
    fn degenerate_weights_are_refused_not_panicked_on() {
        assert!(AliasTable::new(&[]).is_err());
        assert!(AliasTable::new(&[0.0, 0.0]).is_err());
        assert!(AliasTable::new(&[1e308, 1e308]).is_err());
        assert!(AliasTable::new(&[1.0, f64::NAN]).is_err());
        assert!(AliasTable::new(&[1.0, -1.0]).is_err());
    }
}
