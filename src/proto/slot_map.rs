//! A map in key order whose values also lie at numbered slots: a caller that remembers where a
//! key was finds it again with one load and a key compare, not a search. The parameters of a
//! component are one (a PARAM_VALUE of a known index finds its parameter by the slot that index
//! last had, not by a search of ~1,350 names).

use std::borrow::Borrow;
use std::collections::BTreeMap;

/// Values by key (iterated in key order), each kept at a slot whose number stays until it is
/// removed.
#[derive(Debug, Clone)]
pub struct SlotMap<K, V> {
    /// Each key's slot.
    order: BTreeMap<K, u32>,
    /// The values, with their keys (a slot is checked against the key asked for).
    slots: Vec<Option<(K, V)>>,
    /// Empty slots, to be used again.
    free: Vec<u32>,
}

impl<K, V> Default for SlotMap<K, V> {
    fn default() -> Self {
        SlotMap {
            order: BTreeMap::new(),
            slots: Vec::new(),
            free: Vec::new(),
        }
    }
}

impl<K: Ord + Copy, V> SlotMap<K, V> {
    pub fn len(&self) -> usize {
        self.order.len()
    }

    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    pub fn get<Q>(&self, name: &Q) -> Option<&V>
    where
        K: Borrow<Q>,
        Q: Ord + ?Sized,
    {
        let s = *self.order.get(name)?;
        self.slots[s as usize].as_ref().map(|(_, p)| p)
    }

    pub fn get_mut<Q>(&mut self, name: &Q) -> Option<&mut V>
    where
        K: Borrow<Q>,
        Q: Ord + ?Sized,
    {
        let s = *self.order.get(name)?;
        self.slots[s as usize].as_mut().map(|(_, p)| p)
    }

    pub fn contains_key<Q>(&self, name: &Q) -> bool
    where
        K: Borrow<Q>,
        Q: Ord + ?Sized,
    {
        self.order.contains_key(name)
    }

    /// The slot of `name`: `hint` when that slot holds it (no search), else found by name.
    #[inline]
    pub fn slot(&self, name: &K, hint: Option<u32>) -> Option<u32> {
        match hint.and_then(|h| Some((h, self.slots.get(h as usize)?.as_ref()?))) {
            Some((h, (n, _))) if n == name => Some(h),
            _ => self.order.get(name).copied(),
        }
    }

    /// The value at a slot [`SlotMap::slot`] or [`SlotMap::insert_at`] gave (nothing removed
    /// since).
    pub fn at_mut(&mut self, slot: u32) -> &mut V {
        &mut self.slots[slot as usize]
            .as_mut()
            .expect("a slot given by SlotMap::slot")
            .1
    }

    /// Add `param` under `name` (replacing one there); its slot.
    pub fn insert_at(&mut self, name: K, param: V) -> u32 {
        if let Some(&s) = self.order.get(&name) {
            self.slots[s as usize] = Some((name, param));
            return s;
        }
        let s = match self.free.pop() {
            Some(s) => {
                self.slots[s as usize] = Some((name, param));
                s
            }
            None => {
                self.slots.push(Some((name, param)));
                (self.slots.len() - 1) as u32
            }
        };
        self.order.insert(name, s);
        s
    }

    /// Add `param` under `name`; the one there before.
    pub fn insert(&mut self, name: K, param: V) -> Option<V> {
        if let Some(&s) = self.order.get(&name) {
            return self.slots[s as usize]
                .replace((name, param))
                .map(|(_, p)| p);
        }
        self.insert_at(name, param);
        None
    }

    pub fn remove<Q>(&mut self, name: &Q) -> Option<V>
    where
        K: Borrow<Q>,
        Q: Ord + ?Sized,
    {
        let s = self.order.remove(name)?;
        self.free.push(s);
        self.slots[s as usize].take().map(|(_, p)| p)
    }

    /// In name order.
    pub fn iter(&self) -> impl DoubleEndedIterator<Item = (&K, &V)> + '_ {
        self.order.iter().map(|(n, &s)| {
            let (_, p) = self.slots[s as usize]
                .as_ref()
                .expect("a slot in the order");
            (n, p)
        })
    }

    /// In name order.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (&K, &mut V)> + '_ {
        let mut by_slot: Vec<Option<&mut V>> = self
            .slots
            .iter_mut()
            .map(|s| s.as_mut().map(|(_, p)| p))
            .collect();
        self.order.iter().map(move |(n, &s)| {
            let p = by_slot[s as usize]
                .take()
                .expect("each slot once in the order");
            (n, p)
        })
    }

    pub fn keys(&self) -> impl DoubleEndedIterator<Item = &K> + '_ {
        self.order.keys()
    }

    /// In name order.
    pub fn values(&self) -> impl DoubleEndedIterator<Item = &V> + '_ {
        self.iter().map(|(_, p)| p)
    }

    /// In no order.
    pub fn values_mut(&mut self) -> impl Iterator<Item = &mut V> + '_ {
        self.slots.iter_mut().flatten().map(|(_, p)| p)
    }
}

impl<K: Ord + Copy + Borrow<str>, V> std::ops::Index<&str> for SlotMap<K, V> {
    type Output = V;

    fn index(&self, name: &str) -> &V {
        self.get(name).expect("a value under this key")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random inserts, replacements and removals, each checked against `BTreeMap` (the model):
    /// the same values under the same keys, in the same order; and a slot remembered for a key
    /// finds it while it stays, and never another key's value once the slot is used again.
    #[test]
    fn behaves_as_a_btreemap_and_a_remembered_slot_never_finds_another_key() {
        let mut rng = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let mut m: SlotMap<u16, u64> = SlotMap::default();
        let mut model: BTreeMap<u16, u64> = BTreeMap::new();
        let mut remembered: Vec<(u16, u32)> = Vec::new();
        for step in 0..20_000u64 {
            let k = (next() % 300) as u16;
            match next() % 4 {
                0 => {
                    assert_eq!(m.remove(&k), model.remove(&k), "step {step}");
                }
                1 => {
                    assert_eq!(m.insert(k, step), model.insert(k, step), "step {step}");
                }
                _ => {
                    let s = match m.slot(&k, None) {
                        Some(s) => s,
                        None => m.insert_at(k, step),
                    };
                    *m.at_mut(s) += 1;
                    *model.entry(k).or_insert(step) += 1;
                    remembered.push((k, s));
                }
            }
            // Every slot remembered: the key's own slot, or a search, never another key's.
            let (k, s) = remembered[(next() as usize) % remembered.len().max(1)..]
                .first()
                .copied()
                .unwrap_or((0, 0));
            match m.slot(&k, Some(s)) {
                Some(found) => assert_eq!(*m.at_mut(found), model[&k], "step {step}"),
                None => assert!(!model.contains_key(&k), "step {step}"),
            }
        }
        assert_eq!(m.len(), model.len());
        let got: Vec<(u16, u64)> = m.iter().map(|(k, v)| (*k, *v)).collect();
        let want: Vec<(u16, u64)> = model.iter().map(|(k, v)| (*k, *v)).collect();
        assert_eq!(got, want);
        let got: Vec<(u16, u64)> = m.iter_mut().map(|(k, v)| (*k, *v)).collect();
        assert_eq!(got, want);
        // Slots are used again: no more than the most keys held at once.
        assert!(m.slots.len() <= 300);
    }
}
