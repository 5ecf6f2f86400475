//! Disjoint sets over `0..n` (union-find): union by the smaller root, so a set's root is its
//! smallest member whatever the order of the unions, and path halving.

/// Each member's parent; a root is its own.
pub(crate) struct Sets(Vec<u32>);

impl Sets {
    /// `n` singletons.
    pub(crate) fn new(n: usize) -> Self {
        Self((0..n as u32).collect())
    }

    /// Members.
    pub(crate) fn len(&self) -> usize {
        self.0.len()
    }

    /// The root of `i`'s set: its smallest member.
    pub(crate) fn root(&mut self, mut i: u32) -> u32 {
        while self.0[i as usize] != i {
            let up = self.0[self.0[i as usize] as usize];
            self.0[i as usize] = up;
            i = up;
        }
        i
    }

    /// The root of `i`'s set without shortening the path, for readers in parallel.
    pub(crate) fn root_of(&self, mut i: u32) -> u32 {
        while self.0[i as usize] != i {
            i = self.0[i as usize];
        }
        i
    }

    /// Joins the sets of `a` and `b`; whether they were apart.
    pub(crate) fn join(&mut self, a: u32, b: u32) -> bool {
        let (a, b) = (self.root(a), self.root(b));
        self.0[a.max(b) as usize] = a.min(b);
        a != b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_are_the_smallest_members_whatever_the_order() {
        let mut s = Sets::new(6);
        assert!(s.join(5, 3));
        assert!(s.join(3, 4));
        assert!(!s.join(4, 5));
        assert!(s.join(1, 0));
        assert_eq!(
            (0..6).map(|i| s.root_of(i)).collect::<Vec<_>>(),
            [0, 0, 2, 3, 3, 3]
        );
        assert_eq!(
            (0..6).map(|i| s.root(i)).collect::<Vec<_>>(),
            [0, 0, 2, 3, 3, 3]
        );
    }
}
