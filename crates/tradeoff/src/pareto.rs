//! The Pareto front of measured settings (render time against error) and the choice of a
//! setting on it for a time budget or an error target.

/// One measured point: render milliseconds and error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    pub ms: f64,
    pub error: f64,
}

/// Indices of the settings no other setting beats in both time and error, ordered by
/// time: each is strictly more accurate than every faster one. Of equal times the more
/// accurate wins; points with a non-finite time or error are never on the front.
pub fn front(points: &[Point]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].ms.is_finite() && points[i].error.is_finite())
        .collect();
    order.sort_by(|&a, &b| {
        let (p, q) = (points[a], points[b]);
        p.ms.total_cmp(&q.ms).then(p.error.total_cmp(&q.error))
    });
    let mut out: Vec<usize> = Vec::new();
    for i in order {
        if out
            .last()
            .is_none_or(|&j| points[i].error < points[j].error)
        {
            out.push(i);
        }
    }
    out
}

/// What the user asked the choice to meet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal {
    /// The most accurate setting rendering within this many milliseconds.
    BudgetMs(f64),
    /// The fastest setting whose error is at most this.
    TargetError(f64),
}

/// The front entry (an index into `front`, which is ordered by time) meeting `goal`, or
/// a one-line reason when none does.
pub fn choose(points: &[Point], front: &[usize], goal: Goal) -> Result<usize, String> {
    match goal {
        Goal::BudgetMs(t) => front
            .iter()
            .rposition(|&i| points[i].ms <= t)
            .ok_or_else(|| match front.first() {
                Some(&i) => format!(
                    "no setting renders within {t} ms: the fastest measured takes {:.1} ms",
                    points[i].ms
                ),
                None => "the sweep has no measured setting".to_string(),
            }),
        Goal::TargetError(e) => front
            .iter()
            .position(|&i| points[i].error <= e)
            .ok_or_else(|| match front.last() {
                Some(&i) => format!(
                    "no setting reaches error {e}: the most accurate measured has {:.4}",
                    points[i].error
                ),
                None => "the sweep has no measured setting".to_string(),
            }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(ms: f64, error: f64) -> Point {
        Point { ms, error }
    }

    /// The front against its definition checked pair by pair (brute force).
    #[test]
    fn front_is_the_set_of_undominated_points() {
        // A deterministic scatter with ties and a NaN.
        let mut pts: Vec<Point> = (0..40)
            .map(|i| {
                let x = ((i * 37) % 23) as f64;
                let y = ((i * 53) % 17) as f64 / 17.0;
                p(x, y)
            })
            .collect();
        pts.push(p(1.0, f64::NAN));
        let f = front(&pts);
        let dominated = |i: usize| {
            (0..pts.len()).any(|j| {
                j != i
                    && pts[j].error.is_finite()
                    && pts[j].ms <= pts[i].ms
                    && pts[j].error <= pts[i].error
                    && (pts[j].ms < pts[i].ms || pts[j].error < pts[i].error)
            })
        };
        for i in 0..pts.len() {
            let finite = pts[i].error.is_finite();
            // Exact duplicates: only one of them is kept.
            let dup_kept_elsewhere = f.iter().any(|&j| j != i && pts[j] == pts[i]);
            assert_eq!(
                f.contains(&i),
                finite && !dominated(i) && !dup_kept_elsewhere,
                "point {i}: {:?}",
                pts[i]
            );
        }
        for w in f.windows(2) {
            assert!(pts[w[0]].ms <= pts[w[1]].ms && pts[w[0]].error > pts[w[1]].error);
        }
    }

    #[test]
    fn choice_meets_the_budget_or_the_target() {
        let pts = [p(10.0, 0.2), p(20.0, 0.05), p(40.0, 0.01), p(15.0, 0.3)];
        let f = front(&pts);
        assert_eq!(f, vec![0, 1, 2]);
        assert_eq!(f[choose(&pts, &f, Goal::BudgetMs(25.0)).unwrap()], 1);
        assert_eq!(f[choose(&pts, &f, Goal::BudgetMs(1e9)).unwrap()], 2);
        assert!(
            choose(&pts, &f, Goal::BudgetMs(5.0))
                .unwrap_err()
                .contains("10.0 ms")
        );
        assert_eq!(f[choose(&pts, &f, Goal::TargetError(0.1)).unwrap()], 1);
        assert_eq!(f[choose(&pts, &f, Goal::TargetError(0.2)).unwrap()], 0);
        assert!(choose(&pts, &f, Goal::TargetError(0.001)).is_err());
    }
}
