//! Edits of a list of Gaussians and their history (undo/redo).
//!
//! An [`Edit`] is a command: Gaussians changed or deleted, named by their index in the
//! list before the edit with their value before, and Gaussians appended. Applying then
//! reverting it gives back the list exactly (same values, same order).

use haze_gaussians::Gaussian;

/// One undoable change of a list of Gaussians.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Edit {
    /// `(index before the edit, value before, value after or None if deleted)`, indices
    /// ascending and distinct.
    pub changes: Vec<(usize, Gaussian, Option<Gaussian>)>,
    /// Appended after the surviving Gaussians.
    pub added: Vec<Gaussian>,
}

impl Edit {
    /// Whether the edit changes nothing.
    pub fn is_empty(&self) -> bool {
        self.changes.is_empty() && self.added.is_empty()
    }

    /// Applies the edit to `gs` (the list it was made for).
    pub fn apply(&self, gs: &mut Vec<Gaussian>) {
        let mut deleted = vec![false; gs.len()];
        for &(i, _, new) in &self.changes {
            match new {
                Some(g) => gs[i] = g,
                None => deleted[i] = true,
            }
        }
        let mut k = 0;
        gs.retain(|_| {
            k += 1;
            !deleted[k - 1]
        });
        gs.extend_from_slice(&self.added);
    }

    /// Undoes [`Edit::apply`] on `gs`.
    pub fn revert(&self, gs: &mut Vec<Gaussian>) {
        gs.truncate(gs.len() - self.added.len());
        for &(i, old, new) in &self.changes {
            match new {
                Some(_) => {}
                None => gs.insert(i, old),
            }
        }
        for &(i, old, _) in &self.changes {
            gs[i] = old;
        }
    }
}

/// What a stroke has done so far to a list of Gaussians: each one's current value (or
/// `None`, deleted) and those added. [`Draft::gaussians`] is the list to show live,
/// [`Draft::into_edit`] the command the stroke becomes.
#[derive(Clone, Debug)]
pub struct Draft {
    base: Vec<Gaussian>,
    state: Vec<Option<Gaussian>>,
    added: Vec<Gaussian>,
}

impl Draft {
    pub fn new(base: &[Gaussian]) -> Draft {
        Draft {
            base: base.to_vec(),
            state: base.iter().copied().map(Some).collect(),
            added: Vec::new(),
        }
    }

    /// The Gaussians of the list the stroke started from that are still there, with
    /// their index in it.
    pub fn existing(&self) -> impl Iterator<Item = (usize, Gaussian)> + '_ {
        self.state
            .iter()
            .enumerate()
            .filter_map(|(i, g)| g.map(|g| (i, g)))
    }

    /// Sets (or, `None`, deletes) Gaussian `i` of the list the stroke started from.
    pub fn set(&mut self, i: usize, g: Option<Gaussian>) {
        self.state[i] = g;
    }

    pub fn add(&mut self, g: Gaussian) {
        self.added.push(g);
    }

    /// The Gaussians added by the stroke so far.
    pub fn added(&self) -> &[Gaussian] {
        &self.added
    }

    /// The list as the stroke leaves it: the surviving Gaussians in order, then those
    /// added.
    pub fn gaussians(&self) -> Vec<Gaussian> {
        self.state
            .iter()
            .flatten()
            .chain(&self.added)
            .copied()
            .collect()
    }

    /// The stroke as a command on the list it started from.
    pub fn into_edit(self) -> Edit {
        let changes = self
            .base
            .iter()
            .zip(&self.state)
            .enumerate()
            .filter(|(_, (old, new))| Some(**old) != **new)
            .map(|(i, (old, new))| (i, *old, *new))
            .collect();
        Edit {
            changes,
            added: self.added,
        }
    }
}

/// The edited Gaussians with their history.
#[derive(Clone, Debug, Default)]
pub struct Document {
    gaussians: Vec<Gaussian>,
    done: Vec<Edit>,
    undone: Vec<Edit>,
}

impl Document {
    pub fn new(gaussians: Vec<Gaussian>) -> Document {
        Document {
            gaussians,
            ..Default::default()
        }
    }

    pub fn gaussians(&self) -> &[Gaussian] {
        &self.gaussians
    }

    /// A draft of a stroke on the current Gaussians.
    pub fn draft(&self) -> Draft {
        Draft::new(&self.gaussians)
    }

    /// Applies `edit` (made on the current Gaussians) and records it; the redo list is
    /// dropped. An empty edit is not recorded. Whether anything changed.
    pub fn commit(&mut self, edit: Edit) -> bool {
        if edit.is_empty() {
            return false;
        }
        edit.apply(&mut self.gaussians);
        self.done.push(edit);
        self.undone.clear();
        true
    }

    /// Replaces every Gaussian by `gaussians` (a loaded medium), as one undoable edit.
    pub fn replace_all(&mut self, gaussians: Vec<Gaussian>) -> bool {
        let mut d = self.draft();
        for i in 0..self.gaussians.len() {
            d.set(i, None);
        }
        for g in gaussians {
            d.add(g);
        }
        self.commit(d.into_edit())
    }

    /// Undoes the last edit; whether there was one.
    pub fn undo(&mut self) -> bool {
        let Some(e) = self.done.pop() else {
            return false;
        };
        e.revert(&mut self.gaussians);
        self.undone.push(e);
        true
    }

    /// Redoes the last undone edit; whether there was one.
    pub fn redo(&mut self) -> bool {
        let Some(e) = self.undone.pop() else {
            return false;
        };
        e.apply(&mut self.gaussians);
        self.done.push(e);
        true
    }

    /// `(edits to undo, edits to redo)`.
    pub fn depth(&self) -> (usize, usize) {
        (self.done.len(), self.undone.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn g(i: usize) -> Gaussian {
        Gaussian {
            center: [i as f64, 0.5 * i as f64, 1.0],
            radius: 0.1 + 0.01 * i as f64,
            weight: 1.0 + i as f64,
        }
    }

    /// A mixed edit (changes, deletions at both ends and inside, additions) and a
    /// history of three: undo gives back each earlier list exactly, redo each later one.
    #[test]
    fn undo_restores_exactly_and_redo_reapplies() {
        let start: Vec<Gaussian> = (0..7).map(g).collect();
        let mut doc = Document::new(start.clone());
        let mut d = doc.draft();
        d.set(0, None);
        d.set(
            2,
            Some(Gaussian {
                weight: 0.25,
                ..g(2)
            }),
        );
        d.set(3, None);
        d.set(6, None);
        d.add(g(20));
        let seen = d.gaussians();
        assert!(doc.commit(d.into_edit()));
        assert_eq!(doc.gaussians(), seen.as_slice());
        let expected = [
            g(1),
            Gaussian {
                weight: 0.25,
                ..g(2)
            },
            g(4),
            g(5),
            g(20),
        ];
        assert_eq!(doc.gaussians(), &expected[..]);
        let after_one = doc.gaussians().to_vec();
        let mut d = doc.draft();
        d.add(g(30));
        d.add(g(31));
        doc.commit(d.into_edit());
        assert!(doc.replace_all(vec![g(40)]));
        assert_eq!(doc.gaussians(), &[g(40)]);
        assert!(
            !doc.commit(doc.draft().into_edit()),
            "empty edits are not kept"
        );
        assert_eq!(doc.depth(), (3, 0));
        assert!(doc.undo());
        let mut two = after_one.clone();
        two.extend([g(30), g(31)]);
        assert_eq!(doc.gaussians(), two.as_slice());
        assert!(doc.undo() && doc.undo());
        assert_eq!(doc.gaussians(), start.as_slice());
        assert!(!doc.undo());
        assert!(doc.redo());
        assert_eq!(doc.gaussians(), after_one.as_slice());
        assert!(doc.redo() && doc.redo() && !doc.redo());
        assert_eq!(doc.gaussians(), &[g(40)]);
    }
}
