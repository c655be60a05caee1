//! Clipping in data coordinates: segments (Liang–Barsky) and convex polygons (Sutherland–Hodgman)
//! against an axis-aligned rectangle.

/// An axis-aligned rectangle `[x0, x1] × [y0, y1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rect {
    pub x0: f64,
    pub x1: f64,
    pub y0: f64,
    pub y1: f64,
}

impl Rect {
    pub fn contains(&self, p: (f64, f64)) -> bool {
        p.0 >= self.x0 && p.0 <= self.x1 && p.1 >= self.y0 && p.1 <= self.y1
    }
}

/// The part of segment `a`–`b` inside `r`, if any.
pub(crate) fn clip_segment(a: (f64, f64), b: (f64, f64), r: &Rect) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a.0 - r.x0), (dx, r.x1 - a.0), (-dy, a.1 - r.y0), (dy, r.y1 - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
            if t0 > t1 {
                return None;
            }
        }
    }
    Some(((a.0 + t0 * dx, a.1 + t0 * dy), (a.0 + t1 * dx, a.1 + t1 * dy)))
}

/// The part of polygon `poly` inside `r` (exact for convex polygons; `poly` need not be closed).
pub(crate) fn clip_polygon(poly: &[(f64, f64)], r: &Rect) -> Vec<(f64, f64)> {
    type Inside = fn(&Rect, (f64, f64)) -> bool;
    type Cross = fn(&Rect, (f64, f64), (f64, f64)) -> (f64, f64);
    let edges: [(Inside, Cross); 4] = [
        (|r, p| p.0 >= r.x0, |r, a, b| (r.x0, a.1 + (b.1 - a.1) * (r.x0 - a.0) / (b.0 - a.0))),
        (|r, p| p.0 <= r.x1, |r, a, b| (r.x1, a.1 + (b.1 - a.1) * (r.x1 - a.0) / (b.0 - a.0))),
        (|r, p| p.1 >= r.y0, |r, a, b| (a.0 + (b.0 - a.0) * (r.y0 - a.1) / (b.1 - a.1), r.y0)),
        (|r, p| p.1 <= r.y1, |r, a, b| (a.0 + (b.0 - a.0) * (r.y1 - a.1) / (b.1 - a.1), r.y1)),
    ];
    let mut out: Vec<(f64, f64)> = poly.to_vec();
    for (inside, cross) in edges {
        if out.is_empty() {
            break;
        }
        let input = std::mem::take(&mut out);
        let mut prev = *input.last().expect("non-empty");
        for &cur in &input {
            match (inside(r, prev), inside(r, cur)) {
                (true, true) => out.push(cur),
                (true, false) => out.push(cross(r, prev, cur)),
                (false, true) => {
                    out.push(cross(r, prev, cur));
                    out.push(cur);
                }
                (false, false) => {}
            }
            prev = cur;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: Rect = Rect { x0: 0.0, x1: 2.0, y0: 0.0, y1: 1.0 };

    #[test]
    fn segments() {
        assert_eq!(clip_segment((0.5, 0.5), (1.5, 0.5), &R), Some(((0.5, 0.5), (1.5, 0.5))));
        assert_eq!(clip_segment((-1.0, 0.5), (3.0, 0.5), &R), Some(((0.0, 0.5), (2.0, 0.5))));
        assert_eq!(clip_segment((-1.0, 2.0), (3.0, 2.0), &R), None);
        let ((x0, y0), (x1, y1)) = clip_segment((-1.0, -1.0), (3.0, 3.0), &R).unwrap();
        assert_eq!((x0, y0, x1, y1), (0.0, 0.0, 1.0, 1.0));
    }

    #[test]
    fn polygons() {
        let square = [(-1.0, -1.0), (1.0, -1.0), (1.0, 0.5), (-1.0, 0.5)];
        let c = clip_polygon(&square, &R);
        let area: f64 = (0..c.len()).map(|k| {
            let (a, b) = (c[k], c[(k + 1) % c.len()]);
            a.0 * b.1 - b.0 * a.1
        }).sum::<f64>() / 2.0;
        assert!((area.abs() - 0.5).abs() < 1e-12, "{c:?}");
        assert!(c.iter().all(|&p| R.contains(p)));
        assert!(clip_polygon(&[(5.0, 5.0), (6.0, 5.0), (6.0, 6.0)], &R).is_empty());
    }
}
