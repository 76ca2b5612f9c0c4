//! The answers a sweep's rows hold: per requirement, whether each sample met it (all of its
//! scenarios of that requirement passed) and its worst figure; the pass probability with an
//! exact (Clopper-Pearson) confidence interval; percentiles; the worst samples; and the
//! parameters ranked by Spearman's rank correlation with the figure, beside a first-order
//! variance-based (Sobol) index estimated from the same sample by binning.

use std::collections::BTreeMap;

use statrs::distribution::{Beta, ContinuousCDF};

use super::rows::{read_rows, Row, RowsError};

/// One requirement as the rows name it.
#[derive(Debug, Clone, PartialEq)]
pub struct RequirementInfo {
    pub label: String,
    pub unit: String,
    pub limit: f64,
}

/// One sample, reduced to what the answers need.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleRecord {
    pub sample: u64,
    /// Every parameter's value (`None`: the scenario's own wind seed).
    pub values: Vec<Option<f64>>,
    /// Per requirement (in the order of [`SweepData::requirements`]): the worst figure of its
    /// scenarios (+inf if one never settled or failed) and the scenario it came from, and
    /// whether every scenario passed; `None` if the sweep ran none of its scenarios.
    pub outcomes: Vec<Option<RequirementOutcome>>,
}

/// A sample's result for one requirement.
#[derive(Debug, Clone, PartialEq)]
pub struct RequirementOutcome {
    pub worst: f64,
    pub worst_scenario: String,
    pub passed: bool,
}

/// One scenario's figures over the samples.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioStats {
    pub name: String,
    pub requirement: String,
    pub figures: Vec<f64>,
    pub passes: u64,
}

/// A sweep's rows, reduced per sample.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SweepData {
    pub parameter_names: Vec<String>,
    pub requirements: Vec<RequirementInfo>,
    pub samples: Vec<SampleRecord>,
    pub scenarios: Vec<ScenarioStats>,
    /// Samples with a run that failed (the FMUs refused the parameters, or a run stopped): they
    /// are left out of the statistics, counted here, with the first failure's message.
    pub failed_samples: u64,
    pub first_failure: Option<String>,
}

impl SweepData {
    /// Reads a sweep CSV (rows of a sample are consecutive, as every sweep writes them).
    pub fn read(reader: impl std::io::Read, origin: &str) -> Result<SweepData, RowsError> {
        let mut data = SweepData::default();
        let mut current: Vec<Row> = Vec::new();
        let names = read_rows(reader, origin, |_, row| {
            if current.first().is_some_and(|r| r.sample != row.sample) {
                data.add_sample(std::mem::take(&mut current));
            }
            current.push(row);
        })?;
        if !current.is_empty() {
            data.add_sample(current);
        }
        data.parameter_names = names;
        Ok(data)
    }

    fn add_sample(&mut self, rows: Vec<Row>) {
        if let Some(failed) = rows.iter().find(|r| !r.error.is_empty()) {
            self.failed_samples += 1;
            self.first_failure
                .get_or_insert_with(|| format!("sample {}, {}: {}", failed.sample, failed.scenario, failed.error));
            return;
        }
        let mut outcomes: BTreeMap<usize, RequirementOutcome> = BTreeMap::new();
        for row in &rows {
            let requirement = match self.requirements.iter().position(|r| r.label == row.requirement) {
                Some(i) => i,
                None => {
                    self.requirements.push(RequirementInfo {
                        label: row.requirement.clone(),
                        unit: row.unit.clone(),
                        limit: row.limit,
                    });
                    self.requirements.len() - 1
                }
            };
            let figure = if row.figure.is_nan() { f64::INFINITY } else { row.figure };
            let entry = outcomes.entry(requirement).or_insert(RequirementOutcome {
                worst: f64::NEG_INFINITY,
                worst_scenario: String::new(),
                passed: true,
            });
            if figure > entry.worst {
                entry.worst = figure;
                entry.worst_scenario = row.scenario.clone();
            }
            entry.passed &= row.passed;
            let stats = match self.scenarios.iter().position(|s| s.name == row.scenario) {
                Some(i) => &mut self.scenarios[i],
                None => {
                    self.scenarios.push(ScenarioStats {
                        name: row.scenario.clone(),
                        requirement: row.requirement.clone(),
                        figures: Vec::new(),
                        passes: 0,
                    });
                    self.scenarios.last_mut().expect("just pushed")
                }
            };
            stats.figures.push(figure);
            stats.passes += u64::from(row.passed);
        }
        let first = rows.into_iter().next().expect("a sample has rows");
        self.samples.push(SampleRecord {
            sample: first.sample,
            values: first.values,
            outcomes: (0..self.requirements.len()).map(|i| outcomes.remove(&i)).collect(),
        });
    }

    /// The samples that ran requirement `r`: (sample, its outcome).
    pub fn outcomes(&self, r: usize) -> Vec<(&SampleRecord, &RequirementOutcome)> {
        self.samples.iter().filter_map(|s| s.outcomes.get(r).and_then(|o| o.as_ref()).map(|o| (s, o))).collect()
    }

    /// The parameters that vary over the samples (indices into `parameter_names`).
    pub fn varied_parameters(&self) -> Vec<usize> {
        (0..self.parameter_names.len())
            .filter(|&p| {
                let first = self.samples.first().and_then(|s| s.values[p]);
                self.samples.iter().any(|s| s.values[p] != first)
            })
            .collect()
    }
}

/// The exact (Clopper-Pearson) two-sided interval of a probability from `k` successes in `n`
/// trials, at `confidence` (0.95 for 95 %).
pub fn clopper_pearson(k: u64, n: u64, confidence: f64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let alpha = 1.0 - confidence;
    let (k, n) = (k as f64, n as f64);
    let lower = if k == 0.0 {
        0.0
    } else {
        Beta::new(k, n - k + 1.0).expect("positive shape parameters").inverse_cdf(alpha / 2.0)
    };
    let upper = if k == n {
        1.0
    } else {
        Beta::new(k + 1.0, n - k).expect("positive shape parameters").inverse_cdf(1.0 - alpha / 2.0)
    };
    (lower, upper)
}

/// The `q`-quantile (0..1) of sorted values, interpolated linearly between order statistics
/// (Hyndman and Fan's type 7, as numpy's default).
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let position = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (below, above) = (position.floor() as usize, position.ceil() as usize);
    let (a, b) = (sorted[below], sorted[above]);
    if a == b || !a.is_finite() || !b.is_finite() {
        // An infinite neighbour (a run that never settled) makes the quantile infinite too,
        // unless it is hit exactly.
        return if position == below as f64 { a } else { b.max(a) };
    }
    a + (position - below as f64) * (b - a)
}

/// Ranks from 1, ties sharing their average rank; +inf ranks last.
pub fn ranks(values: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut ranks = vec![0.0; values.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && values[order[j + 1]] == values[order[i]] {
            j += 1;
        }
        let average = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            ranks[k] = average;
        }
        i = j + 1;
    }
    ranks
}

/// Pearson's correlation; `None` if either side is constant.
fn pearson(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

/// Spearman's rank correlation of `x` and `y` (ties averaged, +inf ranked last).
pub fn spearman(x: &[f64], y: &[f64]) -> Option<f64> {
    if x.len() < 3 {
        return None;
    }
    pearson(&ranks(x), &ranks(y))
}

/// The first-order variance-based (Sobol) index of `x` for `y`, estimated from one random
/// sample by binning (the "given data" estimator: the variance of the bin means of `y` over
/// equal-count bins of `x`, over the variance of `y`), less its bias under no influence,
/// (bins - 1)/(n - 1). `None` with fewer than 50 samples or a non-finite or constant `y`.
pub fn first_order_index(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len();
    if n < 50 || y.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let bins = ((n as f64).sqrt().round() as usize).clamp(2, 50);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mean = y.iter().sum::<f64>() / n as f64;
    let total: f64 = y.iter().map(|v| (v - mean) * (v - mean)).sum();
    if total <= 0.0 {
        return None;
    }
    let mut between = 0.0;
    for b in 0..bins {
        let members = &order[b * n / bins..(b + 1) * n / bins];
        let bin_mean = members.iter().map(|&i| y[i]).sum::<f64>() / members.len() as f64;
        between += members.len() as f64 * (bin_mean - mean) * (bin_mean - mean);
    }
    let bias = (bins - 1) as f64 / (n - 1) as f64;
    Some(((between / total - bias) / (1.0 - bias)).max(0.0))
}

/// The circular-linear correlation of a figure `y` with an angle `x_deg` (Mardia 1976): the
/// multiple correlation of `y` on `cos x` and `sin x`, from 0 (no dependence a sinusoid of the
/// angle shows) to 1, the same wherever the circle is cut; and the direction (deg in [0, 360))
/// at which that sinusoid is largest. `None` with fewer than 3 samples or a constant `y`.
pub fn circular_linear(x_deg: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    if x_deg.len() < 3 {
        return None;
    }
    let (cos, sin): (Vec<f64>, Vec<f64>) = x_deg.iter().map(|a| (a.to_radians().cos(), a.to_radians().sin())).unzip();
    let (rc, rs) = (pearson(&cos, y)?, pearson(&sin, y)?);
    let rcs = pearson(&cos, &sin).unwrap_or(0.0);
    let squared = ((rc * rc + rs * rs - 2.0 * rc * rs * rcs) / (1.0 - rcs * rcs)).max(0.0);
    // The least-squares sinusoid y ~ a cos x + b sin x peaks at atan2(b, a); its coefficients
    // are the correlations less the other regressor's share.
    let a = rc - rs * rcs;
    let b = rs - rc * rcs;
    Some((squared.sqrt().min(1.0), b.atan2(a).to_degrees().rem_euclid(360.0)))
}

/// One parameter's influence on one requirement's figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Influence {
    pub parameter: usize,
    /// Spearman's rho; for an angle over the whole circle, the circular-linear correlation
    /// (0 to 1), with the direction of the largest figure in `worst_direction_deg`.
    pub spearman: f64,
    pub first_order: Option<f64>,
    /// For an angle over the whole circle, the direction (deg) at which the figure peaks.
    pub worst_direction_deg: Option<f64>,
}

impl Influence {
    /// The share of the figure's variation the parameter accounts for alone: the larger of the
    /// first-order index (any dependence, also one that rises and falls, as a phase's) and
    /// rho squared (a monotone one; all there is below 50 samples).
    pub fn score(&self) -> f64 {
        self.first_order.unwrap_or(0.0).max(self.spearman * self.spearman)
    }
}

/// The varied parameters ranked by their [`Influence::score`] on the sample's worst figure of
/// requirement `r`, largest first.
pub fn sensitivity(data: &SweepData, r: usize) -> Vec<Influence> {
    // The angles over the whole circle, whose correlation is circular.
    let circular: Vec<String> = antenna_fmus::parameters::parameters()
        .into_iter()
        .filter(|p| p.scale == antenna_fmus::parameters::Scale::Circular)
        .map(|p| p.name)
        .collect();
    let outcomes = data.outcomes(r);
    let y: Vec<f64> = outcomes.iter().map(|(_, o)| o.worst).collect();
    let mut ranking: Vec<Influence> = data
        .varied_parameters()
        .into_iter()
        .filter_map(|p| {
            let x: Vec<f64> = outcomes.iter().map(|(s, _)| s.values[p].unwrap_or(f64::NAN)).collect();
            let first_order = first_order_index(&x, &y);
            if circular.contains(&data.parameter_names[p]) {
                let (r, direction) = circular_linear(&x, &y)?;
                return Some(Influence {
                    parameter: p,
                    spearman: r,
                    first_order,
                    worst_direction_deg: Some(direction),
                });
            }
            let rho = spearman(&x, &y)?;
            Some(Influence { parameter: p, spearman: rho, first_order, worst_direction_deg: None })
        })
        .collect();
    ranking.sort_by(|a, b| b.score().total_cmp(&a.score()));
    ranking
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clopper_pearson_matches_published_intervals() {
        // Clopper and Pearson's exact interval; reference values from R's binom.test.
        let (lo, hi) = clopper_pearson(7, 10, 0.95);
        assert!((lo - 0.3475471).abs() < 1e-6 && (hi - 0.9332605).abs() < 1e-6, "{lo} {hi}");
        let (lo, hi) = clopper_pearson(100, 100, 0.95);
        assert!((lo - 0.9637833).abs() < 1e-6 && hi == 1.0, "{lo} {hi}");
        assert_eq!(clopper_pearson(0, 20, 0.95).0, 0.0);
    }

    #[test]
    fn percentiles_interpolate_and_infinite_tails_stay_infinite() {
        let v = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(percentile(&v, 0.5), 2.5);
        assert_eq!(percentile(&v, 1.0), 4.0);
        let w = [1.0, 2.0, f64::INFINITY];
        assert_eq!(percentile(&w, 0.5), 2.0);
        assert_eq!(percentile(&w, 0.9), f64::INFINITY);
    }

    #[test]
    fn the_circular_linear_correlation_sees_a_figure_that_peaks_at_one_direction_wherever_the_circle_is_cut() {
        // A figure largest at 350 deg: a rank correlation on 0-360 deg sees nearly nothing,
        // since 350 and 10 deg lie at opposite ends of the range.
        let x: Vec<f64> = (0..360).map(|k| k as f64 + 0.5).collect();
        let y: Vec<f64> = x.iter().map(|a: &f64| (a - 350.0).to_radians().cos()).collect();
        let (r, direction) = circular_linear(&x, &y).unwrap();
        assert!((r - 1.0).abs() < 1e-9, "{r}");
        assert!((direction - 350.0).abs() < 1e-6, "{direction}");
        assert!(spearman(&x, &y).unwrap().abs() < 0.35, "{:?}", spearman(&x, &y));
        // Shifting where the circle is cut changes nothing.
        let shifted: Vec<f64> = x.iter().map(|a| (a + 180.0).rem_euclid(360.0) - 180.0).collect();
        let (r2, direction2) = circular_linear(&shifted, &y).unwrap();
        assert!((r2 - r).abs() < 1e-9 && (direction2 - direction).abs() < 1e-6);
        // No dependence: a small correlation.
        let flat: Vec<f64> = x.iter().map(|a| ((a * 7.3).sin() * 1e3).fract()).collect();
        assert!(circular_linear(&x, &flat).unwrap().0 < 0.2);
    }

    #[test]
    fn spearman_sees_a_monotone_relation_and_ties_share_ranks() {
        let x: Vec<f64> = (0..20).map(f64::from).collect();
        let y: Vec<f64> = x.iter().map(|v| (v * 0.3).exp()).collect();
        assert!((spearman(&x, &y).unwrap() - 1.0).abs() < 1e-12);
        let falling: Vec<f64> = y.iter().map(|v| -v).collect();
        assert!((spearman(&x, &falling).unwrap() + 1.0).abs() < 1e-12);
        assert_eq!(ranks(&[3.0, 1.0, 3.0, f64::INFINITY]), vec![2.5, 1.0, 2.5, 4.0]);
        assert_eq!(spearman(&x, &[1.0; 20]), None);
    }

    #[test]
    fn the_first_order_index_finds_the_parameter_that_carries_the_variance() {
        // y = 4 x1 + x2 on independent uniforms: S1 = 16/17 and 1/17.
        let n = 4000;
        let plan = super::super::Plan::new(super::super::Method::Random, 1, n, 2).unwrap();
        let points: Vec<Vec<f64>> = (0..n).map(|i| plan.point(i)).collect();
        let x1: Vec<f64> = points.iter().map(|p| p[0]).collect();
        let x2: Vec<f64> = points.iter().map(|p| p[1]).collect();
        let y: Vec<f64> = points.iter().map(|p| 4.0 * p[0] + p[1]).collect();
        let s1 = first_order_index(&x1, &y).unwrap();
        let s2 = first_order_index(&x2, &y).unwrap();
        assert!((s1 - 16.0 / 17.0).abs() < 0.03, "{s1}");
        assert!((s2 - 1.0 / 17.0).abs() < 0.03, "{s2}");
    }
}
