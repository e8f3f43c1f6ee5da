//! A fixed-capacity list on the stack, so the per-triangle hot path does not allocate.
//!
//! A full list drops what is pushed: callers count every drop (`RenderStats::capacity_drops`,
//! through [`SmallList::push_or_count`]), so a cap that is too small shows in the statistics
//! instead of silently losing light.

use arrayvec::ArrayVec;

/// Up to `N` values of `T`; pushing beyond the capacity drops the value and reports it. (An
/// `ArrayVec`: the storage is not initialised until pushed to, so an empty list costs nothing.)
#[derive(Debug, Clone)]
pub struct SmallList<T: Copy, const N: usize> {
    items: ArrayVec<T, N>,
}

impl<T: Copy, const N: usize> Default for SmallList<T, N> {
    fn default() -> Self {
        SmallList {
            items: ArrayVec::new(),
        }
    }
}

impl<T: Copy, const N: usize> SmallList<T, N> {
    /// Appends `value`; false (and the value is dropped) when the list is full.
    #[must_use = "a full list drops the value: count the drop"]
    pub fn push(&mut self, value: T) -> bool {
        self.items.try_push(value).is_ok()
    }

    /// Appends `value`, or adds 1 to `dropped` when the list is full (the value is dropped).
    pub fn push_or_count(&mut self, value: T, dropped: &mut u64) {
        if !self.push(value) {
            *dropped += 1;
        }
    }

    /// The number of values.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether the list holds no value.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// The values in insertion order.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = &mut T> {
        self.items.iter_mut()
    }

    /// The values in order.
    pub fn iter(&self) -> impl Iterator<Item = &T> {
        self.items.iter()
    }

    /// The value at `index`, if any.
    pub fn get(&self, index: usize) -> Option<&T> {
        self.items.get(index)
    }

    /// Mutable access to the value at `index`, if any.
    pub fn get_mut(&mut self, index: usize) -> Option<&mut T> {
        self.items.get_mut(index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_up_to_capacity() {
        let mut list: SmallList<u32, 2> = SmallList::default();
        assert!(list.is_empty());
        assert!(list.push(1) && list.push(2));
        assert!(!list.push(3));
        let mut dropped = 0;
        list.push_or_count(4, &mut dropped);
        assert_eq!(dropped, 1);
        assert_eq!(list.iter().copied().collect::<Vec<_>>(), vec![1, 2]);
        assert_eq!(list.len(), 2);
        *list.get_mut(0).unwrap() = 5;
        assert_eq!(list.get(0), Some(&5));
        assert_eq!(list.get(2), None);
    }
}
