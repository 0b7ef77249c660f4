//! Geometry and instance ids: issued in order, never reused.

use std::collections::BTreeMap;

use crate::{Error, Result};

/// A mesh of a [`super::Scene`]: `0, 1, …` in the order added, never reused after removal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct GeometryId(pub u32);

/// An instance of a mesh in a [`super::Scene`]: `0, 1, …` in the order added, never reused
/// after removal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct InstanceId(pub u32);

impl GeometryId {
    /// No geometry: the id of a miss (`u32::MAX`, never issued).
    pub const NONE: GeometryId = GeometryId(u32::MAX);
}

impl InstanceId {
    /// No instance: the id of a miss and of a hit on a mesh traced as it is (`u32::MAX`, never
    /// issued).
    pub const NONE: InstanceId = InstanceId(u32::MAX);
}

/// Items under ids that count up from 0 and stop short of `u32::MAX`, so that no id is issued
/// twice and the invalid id is never issued.
#[derive(Clone, Debug)]
pub(super) struct Slots<T> {
    items: BTreeMap<u32, T>,
    next: u32,
    kind: &'static str,
}

impl<T> Slots<T> {
    pub(super) fn new(kind: &'static str) -> Self {
        Slots {
            items: BTreeMap::new(),
            next: 0,
            kind,
        }
    }

    /// Stores `item` under the next id.
    pub(super) fn insert(&mut self, item: T) -> Result<u32> {
        if self.next == u32::MAX {
            return Err(Error::IdsExhausted(self.kind));
        }
        let id = self.next;
        self.next += 1;
        self.items.insert(id, item);
        Ok(id)
    }

    pub(super) fn get(&self, id: u32) -> Option<&T> {
        self.items.get(&id)
    }

    pub(super) fn get_mut(&mut self, id: u32) -> Option<&mut T> {
        self.items.get_mut(&id)
    }

    pub(super) fn remove(&mut self, id: u32) -> Option<T> {
        self.items.remove(&id)
    }

    pub(super) fn len(&self) -> usize {
        self.items.len()
    }

    /// Live items in id order.
    pub(super) fn iter(&self) -> impl Iterator<Item = (u32, &T)> {
        self.items.iter().map(|(&id, t)| (id, t))
    }

    /// Live items in id order, mutably.
    pub(super) fn iter_mut(&mut self) -> impl Iterator<Item = (u32, &mut T)> {
        self.items.iter_mut().map(|(&id, t)| (id, t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_count_up_and_are_never_reused() {
        let mut s = Slots::new("test");
        assert_eq!(s.insert('a').unwrap(), 0);
        assert_eq!(s.insert('b').unwrap(), 1);
        assert_eq!(s.remove(1), Some('b'));
        assert_eq!(s.insert('c').unwrap(), 2);
        assert!(s.get(1).is_none());
        s.next = u32::MAX - 1;
        assert_eq!(s.insert('d').unwrap(), u32::MAX - 1);
        assert!(matches!(s.insert('e'), Err(Error::IdsExhausted("test"))));
        assert_eq!(s.len(), 3);
    }
}
