//! Copy and paste (paper B §6): a rectangle drawn on the screen selects the Gaussians
//! whose centres project inside it (in front of the eye, through [`Camera::project`]);
//! they can be copied, or cut (to move them), then pasted at another image point. A paste
//! puts the group's centroid on the cursor's ray at the depth (distance along the view
//! direction) it was copied from, so a group moves across the screen as the cursor does;
//! every Gaussian keeps its radius and weight and moves by the same vector.

use super::Draft;
use crate::Camera;
use crate::vec3::{Vec3, dot, sub};
use haze_gaussians::Gaussian;

/// A screen rectangle: two opposite corners in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub a: (f64, f64),
    pub b: (f64, f64),
}

impl Rect {
    pub fn contains(&self, (x, y): (f64, f64)) -> bool {
        let (x0, x1) = (self.a.0.min(self.b.0), self.a.0.max(self.b.0));
        let (y0, y1) = (self.a.1.min(self.b.1), self.a.1.max(self.b.1));
        (x0..=x1).contains(&x) && (y0..=y1).contains(&y)
    }
}

/// Indices (in `draft`'s starting list) of the Gaussians the rectangle selects.
pub fn select(draft: &Draft, camera: &Camera, rect: Rect) -> Vec<usize> {
    draft
        .existing()
        .filter(|(_, g)| camera.project(g.center).is_some_and(|p| rect.contains(p)))
        .map(|(i, _)| i)
        .collect()
}

/// Copied Gaussians with where they came from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Clipboard {
    pub gaussians: Vec<Gaussian>,
    /// Their centroid (of the centres).
    pub centroid: Vec3,
    /// The centroid's depth along the copying camera's view direction.
    pub depth: f64,
}

impl Clipboard {
    /// Copies the Gaussians the rectangle selects; `cut` also deletes them from `draft`.
    /// An empty clipboard when the rectangle selects none.
    pub fn take(draft: &mut Draft, camera: &Camera, rect: Rect, cut: bool) -> Clipboard {
        let picked = select(draft, camera, rect);
        let all: Vec<(usize, Gaussian)> = draft.existing().collect();
        let gaussians: Vec<Gaussian> = all
            .iter()
            .filter(|(i, _)| picked.binary_search(i).is_ok())
            .map(|(_, g)| *g)
            .collect();
        if cut {
            for &i in &picked {
                draft.set(i, None);
            }
        }
        if gaussians.is_empty() {
            return Clipboard::default();
        }
        let n = gaussians.len() as f64;
        let centroid = [0, 1, 2].map(|a| gaussians.iter().map(|g| g.center[a]).sum::<f64>() / n);
        Clipboard {
            depth: dot(sub(centroid, camera.eye), camera.forward()),
            centroid,
            gaussians,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.gaussians.is_empty()
    }

    /// The vector a paste at image point `(px, py)` of `camera` moves the copies by.
    pub fn offset(&self, camera: &Camera, px: f64, py: f64) -> Vec3 {
        let d = camera.ray(px, py);
        let along = dot(d, camera.forward());
        let t = if along > 0.0 {
            self.depth / along
        } else {
            self.depth
        };
        [0, 1, 2].map(|a| camera.eye[a] + t * d[a] - self.centroid[a])
    }

    /// Pastes the copies at image point `(px, py)` into `draft`.
    pub fn paste(&self, draft: &mut Draft, camera: &Camera, px: f64, py: f64) {
        let off = self.offset(camera, px, py);
        for g in &self.gaussians {
            draft.add(Gaussian {
                center: [0, 1, 2].map(|a| g.center[a] + off[a]),
                ..*g
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::Document;
    use crate::vec3::norm;

    /// Gaussians placed through known pixels (on a 10-pixel lattice, at depths 3 to 7):
    /// the rectangle [30, 90] × [10, 40] selects exactly those of pixels x ∈ {35, …, 85},
    /// y ∈ {15, 25, 35}; pasting at (150, 70) adds them moved by one vector, which brings
    /// their centroid to the cursor's ray at the copied depth; cut + paste moves them; undo
    /// restores the list.
    #[test]
    fn copy_paste_and_cut_move_the_selected_gaussians_by_one_offset() {
        let cam = Camera::new(
            [1.0, -2.0, 0.5],
            [1.0, 5.0, 0.0],
            [0.0, 0.0, 1.0],
            50.0,
            200,
            100,
        )
        .unwrap();
        let mut gs = Vec::new();
        let mut inside = Vec::new();
        for (k, (x, y)) in (0..20)
            .flat_map(|i| (0..10).map(move |j| (5.0 + 10.0 * i as f64, 5.0 + 10.0 * j as f64)))
            .enumerate()
        {
            let depth = 3.0 + (k % 5) as f64;
            let d = cam.ray(x, y);
            let t = depth / dot(d, cam.forward());
            gs.push(Gaussian {
                center: [0, 1, 2].map(|a| cam.eye[a] + t * d[a]),
                radius: 0.1 + 0.001 * k as f64,
                weight: 0.5 + 0.01 * k as f64,
            });
            if (30.0..=90.0).contains(&x) && (10.0..=40.0).contains(&y) {
                inside.push(k);
            }
        }
        let rect = Rect {
            a: (90.0, 10.0),
            b: (30.0, 40.0),
        };
        let mut doc = Document::new(gs.clone());
        let mut d = doc.draft();
        assert_eq!(select(&d, &cam, rect), inside);
        assert_eq!(inside.len(), 6 * 3);
        let clip = Clipboard::take(&mut d, &cam, rect, false);
        clip.paste(&mut d, &cam, 150.0, 70.0);
        let pasted = d.added().to_vec();
        assert_eq!(pasted.len(), inside.len());
        let off = sub(pasted[0].center, gs[inside[0]].center);
        for (p, &k) in pasted.iter().zip(&inside) {
            assert_eq!((p.radius, p.weight), (gs[k].radius, gs[k].weight));
            assert!(norm(sub(sub(p.center, gs[k].center), off)) < 1e-12);
        }
        // The pasted centroid lies on the ray through (150, 70) at the copied depth.
        let n = pasted.len() as f64;
        let c = [0, 1, 2].map(|a| pasted.iter().map(|g| g.center[a]).sum::<f64>() / n);
        let (px, py) = cam.project(c).unwrap();
        assert!((px - 150.0).abs() < 1e-9 && (py - 70.0).abs() < 1e-9);
        assert!((dot(sub(c, cam.eye), cam.forward()) - clip.depth).abs() < 1e-9);
        assert!(doc.commit(d.into_edit()));
        assert_eq!(doc.gaussians().len(), gs.len() + inside.len());
        // Cut and paste: a move.
        let mut d = doc.draft();
        let clip = Clipboard::take(&mut d, &cam, rect, true);
        clip.paste(&mut d, &cam, 20.0, 80.0);
        assert!(doc.commit(d.into_edit()));
        assert_eq!(doc.gaussians().len(), gs.len() + inside.len());
        assert!(doc.undo() && doc.undo());
        assert_eq!(doc.gaussians(), gs.as_slice());
        // A rectangle with nothing inside copies nothing.
        let mut d = doc.draft();
        let empty = Rect {
            a: (-50.0, -50.0),
            b: (-10.0, -10.0),
        };
        assert!(Clipboard::take(&mut d, &cam, empty, false).is_empty());
    }
}
