//! Per-contact history declared by a law, as a type: storage beside the neighbor list, its
//! carry-over across list rebuilds, its reset when a contact opens and its checkpoint round trip
//! are written here once, generic over that type.
//!
//! A law whose contacts remember something beyond the shared parts (tangential spring, rolling
//! and twisting springs, last overlap, sliding) declares it — a normal law as its
//! `NormalLaw::History`, a tangential law as its `TangentialLaw::Extra`, a law with both as the
//! pair of the two — as [`LawParts::Extra`](super::LawParts::Extra):
//! a small `Copy + Default` value implementing [`LawHistory`]. Every existing law declares `()`,
//! which occupies no memory, is never stored, serialized or copied, and compiles to the code of
//! a law without it. The engine keeps one [`HistoryColumn`] per pair list: `Vec<H>` for the
//! law's `H`, one entry per candidate pair in list order, behind a type-erased box that the force
//! pass opens as `&mut [H]` once per pass ([`HistoryColumn::typed_mut`]). An entry is
//! `H::default()` when the pair is not in contact (the force pass resets it when the contact
//! opens), is carried to the pair's new index when the list is rebuilt
//! ([`HistoryColumn::remap`]), and is written to checkpoints as the law's bit-exact `f64`
//! encoding under its name ([`LawHistory::name`]) — no flat offsets into a shared array.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::any::Any;
use std::borrow::Cow;
use std::cell::Cell;
use std::fmt::Debug;

/// The per-contact history of a law beyond the shared parts (see the module documentation).
///
/// `Default` is the state of a contact that has just formed. The encoding must be bit-exact:
/// `decode(encode(h)) == h` to the bit, so that a checkpoint resumes the run it was taken from.
pub trait LawHistory: Copy + Default + PartialEq + Debug + Send + Sync + 'static {
    /// Name of the history in checkpoints (a column is only read back by the law that wrote it).
    const NAME: &'static str;
    /// The name a column of this history is written and read back under: [`LawHistory::NAME`]
    /// for a law's own history; for the history of a composed law, the names of its parts
    /// (`"<normal>+<tangential>"`, the pair's impl).
    #[inline]
    fn name() -> Cow<'static, str> {
        Cow::Borrowed(Self::NAME)
    }
    /// Number of `f64` values of the encoding.
    const WIDTH: usize;
    /// The history as one value per lane of a lane type `R` (the form the lane-generic contact
    /// law reads and writes: `R` = `f64` on the general kernel).
    type Lanes<R: crate::real::Real>: Copy;
    /// The one-lane form.
    fn to_lane(self) -> Self::Lanes<f64>;
    /// Back from the one-lane form.
    fn from_lane(l: Self::Lanes<f64>) -> Self;
    /// This value on every lane of `R`.
    fn splat<R: crate::real::Real>(self) -> Self::Lanes<R>;
    /// The histories of several contacts, one per lane of `R`: lane `l` is `at(l)` for
    /// `l < R::LANES` (the fused kernels gather their contacts' histories so, beside the
    /// tangential springs; with `R::from_fn` per `f64` of the history).
    fn gather<R: crate::real::Real>(at: impl FnMut(usize) -> Self) -> Self::Lanes<R>;
    /// Back from one history per lane: `put(l, h)` with the history `h` of lane `l`, for every
    /// lane of `R` in lane order (with `Real::for_each_lane` per `f64` of the history).
    fn scatter<R: crate::real::Real>(lanes: Self::Lanes<R>, put: impl FnMut(usize, Self));
    /// Appends the `WIDTH` values of the encoding.
    fn encode(&self, out: &mut Vec<f64>);
    /// Reads the `WIDTH` values written by [`LawHistory::encode`].
    fn decode(values: &[f64]) -> Self;
    /// The history seen from the other grain of the pair, used when a rebuild finds that the
    /// two grains swapped storage order (histories act on the grain of smaller index): vectors
    /// on the owner change sign. The identity for scalars (the default).
    #[inline]
    fn reversed(self) -> Self {
        self
    }
    /// Runs `v` with the parts of `law`, whose normal part `normal` declares this history, as
    /// a type that reaches every history the law declares: with the tangential part's
    /// ([`Tangential::route_with_normal`](super::Tangential::route_with_normal)), the
    /// composition [`WithNormal`](super::WithNormal) or, where the tangential law keeps one too,
    /// [`WithBoth`](super::WithBoth) (the default); for `()` the tangential part's route alone
    /// ([`Tangential::route`](super::Tangential::route)), which is the general law itself for a
    /// tangential law without history, so that the laws without history share one general
    /// force pass.
    #[inline(always)]
    fn route_normal<N: super::NormalLaw<History = Self>, V: super::parts::VisitParts>(law: &super::ContactLaw, normal: N, v: V) -> V::Out {
        super::Tangential::route_with_normal(law, normal, v)
    }
    /// Runs `v` with the parts of `law`, whose tangential part `tangential` declares this
    /// history and whose normal part none: the composition
    /// [`WithTangential`](super::WithTangential) (the default), or for `()` the general law
    /// itself.
    #[inline(always)]
    fn route_tangential<T: super::TangentialLaw<Extra = Self>, V: super::parts::VisitParts>(law: &super::ContactLaw, tangential: T, v: V) -> V::Out {
        v.visit(&super::WithTangential { law: *law, tangential })
    }
    /// Runs `v` with `tangential`, whose law declares this history, as its type
    /// ([`VisitTangential::visit`](super::VisitTangential::visit)): the specialised compositions
    /// of a tangential law with history (`Specialized::TangentialHistory`,
    /// [`HistoryTangential`](super::HistoryTangential)). For `()`
    /// [`VisitTangential::without_history`](super::VisitTangential::without_history) instead.
    #[inline(always)]
    fn route_tangential_history<T: super::TangentialLaw<Extra = Self>, V: super::VisitTangential>(tangential: T, v: V) -> V::Out {
        v.visit(tangential)
    }
    /// Runs `v` with the parts of `law`, whose normal part `normal` and tangential part
    /// `tangential` (declaring this history) both keep one: [`WithBoth`](super::WithBoth),
    /// whose history is the pair of theirs (the default); for `()` [`WithNormal`](super::WithNormal).
    #[inline(always)]
    fn route_both<N: super::NormalLaw, T: super::TangentialLaw<Extra = Self>, V: super::parts::VisitParts>(law: &super::ContactLaw, normal: N, tangential: T, v: V) -> V::Out {
        v.visit(&super::WithBoth { law: *law, normal, tangential })
    }
    /// Runs `v` with `normal`, whose law declares this history, as its type
    /// ([`VisitNormal::visit`](super::VisitNormal::visit)): the specialised compositions of a
    /// normal law with history (`Specialized::NormalHistory`, [`HistoryNormal`](super::HistoryNormal)).
    /// For `()` [`VisitNormal::without_history`](super::VisitNormal::without_history) instead,
    /// so that no kernel is compiled through this route for a law without history (those have
    /// their own specialised compositions).
    #[inline(always)]
    fn route_history<N: super::NormalLaw<History = Self>, V: super::parts::VisitNormal>(normal: N, v: V) -> V::Out {
        v.visit(normal)
    }
}

/// No history beyond the shared parts: every existing law.
impl LawHistory for () {
    const NAME: &'static str = "none";
    const WIDTH: usize = 0;
    type Lanes<R: crate::real::Real> = ();
    #[inline(always)]
    fn to_lane(self) {}
    #[inline(always)]
    fn from_lane(_: ()) {}
    #[inline(always)]
    fn splat<R: crate::real::Real>(self) {}
    #[inline(always)]
    fn gather<R: crate::real::Real>(_: impl FnMut(usize) -> Self) {}
    #[inline(always)]
    fn scatter<R: crate::real::Real>(_: (), _: impl FnMut(usize, Self)) {}
    #[inline(always)]
    fn route_normal<N: super::NormalLaw<History = ()>, V: super::parts::VisitParts>(law: &super::ContactLaw, _normal: N, v: V) -> V::Out {
        super::Tangential::route(law, v)
    }
    #[inline(always)]
    fn route_tangential<T: super::TangentialLaw<Extra = ()>, V: super::parts::VisitParts>(law: &super::ContactLaw, _tangential: T, v: V) -> V::Out {
        v.visit(law)
    }
    #[inline(always)]
    fn route_tangential_history<T: super::TangentialLaw<Extra = ()>, V: super::VisitTangential>(_tangential: T, v: V) -> V::Out {
        v.without_history()
    }
    #[inline(always)]
    fn route_both<N: super::NormalLaw, T: super::TangentialLaw<Extra = ()>, V: super::parts::VisitParts>(law: &super::ContactLaw, normal: N, _tangential: T, v: V) -> V::Out {
        v.visit(&super::WithNormal { law: *law, normal })
    }
    #[inline(always)]
    fn route_history<N: super::NormalLaw<History = ()>, V: super::parts::VisitNormal>(_normal: N, v: V) -> V::Out {
        v.without_history()
    }
    #[inline(always)]
    fn encode(&self, _: &mut Vec<f64>) {}
    #[inline(always)]
    fn decode(_: &[f64]) {}
}

/// `impl LawHistory` for a one-value history, a tuple struct over one `f64` (e.g. the
/// hysteretic law's largest overlap, the slip-weakening law's accumulated slip): one lane of
/// `R` per contact, one `f64` in checkpoints, written under `$name`.
/// `scalar_history!(MaxOverlap, "hysteretic.max_overlap");`
macro_rules! scalar_history {
    ($ty:ident, $name:literal) => {
        impl $crate::contact::LawHistory for $ty {
            const NAME: &'static str = $name;
            const WIDTH: usize = 1;
            type Lanes<R: $crate::real::Real> = R;
            #[inline(always)]
            fn to_lane(self) -> f64 {
                self.0
            }
            #[inline(always)]
            fn from_lane(l: f64) -> Self {
                $ty(l)
            }
            #[inline(always)]
            fn splat<R: $crate::real::Real>(self) -> R {
                R::splat(self.0)
            }
            #[inline(always)]
            fn gather<R: $crate::real::Real>(mut at: impl FnMut(usize) -> Self) -> R {
                R::from_fn(|l| at(l).0)
            }
            #[inline(always)]
            fn scatter<R: $crate::real::Real>(lanes: R, mut put: impl FnMut(usize, Self)) {
                lanes.for_each_lane(|l, x| put(l, $ty(x)))
            }
            fn encode(&self, out: &mut Vec<f64>) {
                out.push(self.0);
            }
            fn decode(values: &[f64]) -> Self {
                $ty(values[0])
            }
        }
    };
}
pub(crate) use scalar_history;

/// The histories of two parts of a composed law side by side (a normal law's and a tangential
/// law's, [`WithBoth`](super::WithBoth)): the first part's encoding then the second's, written
/// under the name `"<first>+<second>"`, reversed part by part.
impl<A: LawHistory, B: LawHistory> LawHistory for (A, B) {
    /// Not used: the pair's column is named by [`LawHistory::name`], from its parts' names.
    const NAME: &'static str = "pair";
    const WIDTH: usize = A::WIDTH + B::WIDTH;
    type Lanes<R: crate::real::Real> = (A::Lanes<R>, B::Lanes<R>);
    fn name() -> Cow<'static, str> {
        Cow::Owned(format!("{}+{}", A::name(), B::name()))
    }
    #[inline(always)]
    fn to_lane(self) -> Self::Lanes<f64> {
        (self.0.to_lane(), self.1.to_lane())
    }
    #[inline(always)]
    fn from_lane(l: Self::Lanes<f64>) -> Self {
        (A::from_lane(l.0), B::from_lane(l.1))
    }
    #[inline(always)]
    fn splat<R: crate::real::Real>(self) -> Self::Lanes<R> {
        (self.0.splat::<R>(), self.1.splat::<R>())
    }
    #[inline(always)]
    fn gather<R: crate::real::Real>(mut at: impl FnMut(usize) -> Self) -> Self::Lanes<R> {
        (A::gather::<R>(|l| at(l).0), B::gather::<R>(|l| at(l).1))
    }
    #[inline(always)]
    fn scatter<R: crate::real::Real>(lanes: Self::Lanes<R>, mut put: impl FnMut(usize, Self)) {
        // the first parts of every lane, then each lane's pair (at most 16 lanes: 512-bit
        // vectors of f32 and narrower lane types than the engine has)
        let mut first = [A::default(); 16];
        assert!(R::LANES <= first.len());
        A::scatter::<R>(lanes.0, |l, a| first[l] = a);
        B::scatter::<R>(lanes.1, |l, b| put(l, (first[l], b)));
    }
    fn encode(&self, out: &mut Vec<f64>) {
        self.0.encode(out);
        self.1.encode(out);
    }
    fn decode(values: &[f64]) -> Self {
        (A::decode(&values[..A::WIDTH]), B::decode(&values[A::WIDTH..A::WIDTH + B::WIDTH]))
    }
    #[inline]
    fn reversed(self) -> Self {
        (self.0.reversed(), self.1.reversed())
    }
}

/// A column of one history type, type-erased (see [`HistoryColumn`]).
trait Column: Any + Debug + Send + Sync {
    fn len(&self) -> usize;
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
    fn clone_box(&self) -> Box<dyn Column>;
    /// The column after a rebuild: entry `p` is the old entry `from[p].0` (reversed where
    /// `from[p].1`), or the default where `from[p].0` is `u32::MAX` (a new pair).
    fn remap(&self, from: &[(u32, bool)]) -> Box<dyn Column>;
    fn encoded(&self) -> Encoded;
}

/// The column of history type `H`.
#[derive(Clone, Debug)]
struct Typed<H: LawHistory>(Vec<H>);

/// A column as written in a checkpoint: the law's name, the width of its encoding and the
/// values, until the force pass of that law asks for it as its type.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Encoded {
    name: String,
    width: u32,
    values: Vec<f64>,
}

impl<H: LawHistory> Column for Typed<H> {
    fn len(&self) -> usize {
        self.0.len()
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
    fn clone_box(&self) -> Box<dyn Column> {
        Box::new(self.clone())
    }
    fn remap(&self, from: &[(u32, bool)]) -> Box<dyn Column> {
        let old = &self.0;
        Box::new(Typed::<H>(
            from.iter()
                .map(|&(o, flip)| match old.get(o as usize) {
                    Some(&h) if flip => h.reversed(),
                    Some(&h) => h,
                    None => H::default(),
                })
                .collect(),
        ))
    }
    fn encoded(&self) -> Encoded {
        let mut values = Vec::with_capacity(self.0.len() * H::WIDTH);
        for h in &self.0 {
            h.encode(&mut values);
        }
        Encoded { name: H::name().into_owned(), width: H::WIDTH as u32, values }
    }
}

impl Column for Encoded {
    fn len(&self) -> usize {
        if self.width == 0 {
            0
        } else {
            self.values.len() / self.width as usize
        }
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
    fn clone_box(&self) -> Box<dyn Column> {
        Box::new(self.clone())
    }
    fn remap(&self, from: &[(u32, bool)]) -> Box<dyn Column> {
        // (not reached: the force pass decodes a loaded column before any rebuild; kept exact
        // anyway, without reversal, which needs the type)
        let w = self.width as usize;
        let mut values = Vec::with_capacity(from.len() * w);
        for &(o, _) in from {
            match self.values.get(o as usize * w..(o as usize + 1) * w) {
                Some(v) if (o as usize) < self.len() => values.extend_from_slice(v),
                _ => values.extend(std::iter::repeat_n(0.0, w)),
            }
        }
        Box::new(Encoded { name: self.name.clone(), width: self.width, values })
    }
    fn encoded(&self) -> Encoded {
        self.clone()
    }
}

/// The law's history of every pair of a list, in list order (see the module documentation).
/// Empty for laws without history (`()`), and until a law with history first runs.
#[derive(Debug, Default)]
pub struct HistoryColumn(Option<Box<dyn Column>>);

impl Clone for HistoryColumn {
    fn clone(&self) -> Self {
        HistoryColumn(self.0.as_ref().map(|c| c.clone_box()))
    }
}

impl PartialEq for HistoryColumn {
    fn eq(&self, other: &Self) -> bool {
        self.0.as_ref().map(|c| c.encoded()) == other.0.as_ref().map(|c| c.encoded())
    }
}

impl HistoryColumn {
    /// True when a law with history has stored (or a checkpoint has loaded) entries.
    pub fn is_stored(&self) -> bool {
        self.0.is_some()
    }

    /// The stored entries as their encodings, in list order (nothing when none is stored).
    pub fn values(&self) -> Vec<f64> {
        self.0.as_ref().map(|c| c.encoded().values).unwrap_or_default()
    }

    /// The name of the stored history ([`LawHistory::name`]; none when nothing is stored).
    pub fn name(&self) -> Option<String> {
        self.0.as_ref().map(|c| c.encoded().name)
    }

    /// Number of entries stored (0 when none).
    pub fn len(&self) -> usize {
        self.0.as_ref().map_or(0, |c| c.len())
    }

    /// True when no entry is stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The column as `&mut [H]` with `len` entries: the stored one, decoded from a checkpoint
    /// on first use, or all `H::default()` where none is stored or the stored one is of another
    /// law (a law changed between runs starts its contacts afresh). `()` stores nothing.
    pub fn typed_mut<H: LawHistory>(&mut self, len: usize) -> &mut [H] {
        if std::mem::size_of::<H>() == 0 {
            return zero_sized_slice(len);
        }
        let stored = self.0.as_ref().filter(|c| c.len() == len);
        if !stored.is_some_and(|c| c.as_any().is::<Typed<H>>()) {
            let decoded = stored
                .and_then(|c| c.as_any().downcast_ref::<Encoded>())
                .filter(|e| e.name == H::name() && e.width as usize == H::WIDTH && H::WIDTH > 0)
                .map(|e| e.values.chunks_exact(H::WIDTH).map(H::decode).collect());
            self.0 = Some(Box::new(Typed::<H>(decoded.unwrap_or_else(|| vec![H::default(); len]))));
        }
        &mut self.0.as_mut().unwrap().as_any_mut().downcast_mut::<Typed<H>>().unwrap().0
    }

    /// Entry `p` of a column for a list of `len` pairs, read without changing the column: the
    /// stored value, decoded where the column is still a checkpoint's encoding, or
    /// `H::default()` (the state of a contact that has just formed) where none is stored, the
    /// stored one is of another law or of another list (its length not `len`), as
    /// [`HistoryColumn::typed_mut`] would give it.
    pub fn get<H: LawHistory>(&self, len: usize, p: usize) -> H {
        if std::mem::size_of::<H>() == 0 || p >= len {
            return H::default();
        }
        let Some(c) = self.0.as_ref().filter(|c| c.len() == len) else {
            return H::default();
        };
        if let Some(t) = c.as_any().downcast_ref::<Typed<H>>() {
            return t.0[p];
        }
        c.as_any()
            .downcast_ref::<Encoded>()
            .filter(|e| e.name == H::name() && e.width as usize == H::WIDTH)
            .map_or_else(H::default, |e| H::decode(&e.values[p * H::WIDTH..(p + 1) * H::WIDTH]))
    }

    /// The column for a rebuilt list: entry `p` is the old entry `from[p].0`, reversed
    /// ([`LawHistory::reversed`]) where `from[p].1`, or the default where `from[p].0` is
    /// `u32::MAX` (a pair that is new to the list). Empty stays empty.
    pub(crate) fn remap(&self, from: &[(u32, bool)]) -> HistoryColumn {
        HistoryColumn(self.0.as_ref().map(|c| c.remap(from)))
    }
}

/// `len` values of a zero-sized history (`()`), without memory and without a loop over them
/// (`vec![(); len]` would count to `len`: measured, ≈ 8 instructions per grain and step in the
/// force pass of hertz3d).
#[inline(always)]
pub(crate) fn zero_sized_slice<'a, H: LawHistory>(len: usize) -> &'a mut [H] {
    assert!(std::mem::size_of::<H>() == 0);
    // SAFETY: a zero-sized type occupies no memory: a dangling, aligned, non-null pointer is a
    // valid slice of any length of it (its byte size, 0, is within isize::MAX); `H: Default +
    // Copy` has no invariant a value could break, and every value of a zero-sized type is the
    // same.
    unsafe { std::slice::from_raw_parts_mut(std::ptr::NonNull::<H>::dangling().as_ptr(), len) }
}

thread_local! {
    /// The checkpoint format version being decoded (or written, in the compatibility tests):
    /// the history columns a file of that version holds. `u32::MAX`: the current layout.
    static VERSION: Cell<u32> = const { Cell::new(u32::MAX) };
}

/// The first format version with the grain–grain pair list's column ([`HistoryColumn`]).
const PAIR_COLUMNS_SINCE: u32 = 3;
/// The first format version with the grain–wall columns ([`WallHistory`]).
const WALL_COLUMNS_SINCE: u32 = 4;

/// Runs `f` (a decoder, or an encoder in tests) with the history columns of format `version`:
/// none before version 3 (whose laws had no history), the pair list's but no grain–wall
/// columns in version 3 (whose wall laws could not have history), all of them since 4.
pub(crate) fn decoding_version<T>(version: u32, f: impl FnOnce() -> T) -> T {
    let before = VERSION.with(|v| v.replace(version));
    let out = f();
    VERSION.with(|v| v.set(before));
    out
}

/// True when the format being decoded holds the columns written since `since`.
fn has_columns(since: u32) -> bool {
    VERSION.with(|v| v.get()) >= since
}

impl Serialize for HistoryColumn {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if !has_columns(PAIR_COLUMNS_SINCE) {
            // (the version 2 layout, for the compatibility tests: nothing)
            return s.serialize_unit();
        }
        self.0.as_ref().map(|c| c.encoded()).serialize(s)
    }
}

impl<'de> Deserialize<'de> for HistoryColumn {
    fn deserialize<De: Deserializer<'de>>(d: De) -> Result<Self, De::Error> {
        if !has_columns(PAIR_COLUMNS_SINCE) {
            return Ok(HistoryColumn(None));
        }
        let e = Option::<Encoded>::deserialize(d)?;
        if let Some(e) = &e {
            if e.width as usize > 64 || (e.width == 0 && !e.values.is_empty()) || (e.width > 0 && e.values.len() % e.width as usize != 0) {
                return Err(serde::de::Error::custom(format!(
                    "history column `{}`: {} values do not make whole entries of width {}",
                    e.name,
                    e.values.len(),
                    e.width
                )));
            }
        }
        Ok(HistoryColumn(e.map(|e| Box::new(e) as Box<dyn Column>)))
    }
}

/// The laws' own history of the grain–wall contacts: one [`HistoryColumn`] per wall (indexed by
/// wall; a column is stored only for a wall whose law keeps a history), each with one entry per
/// grain–wall candidate pair in the order of the neighbor list's `wall_pairs` (entries of other
/// walls' pairs stay the default). Carried across rebuilds and written to checkpoints like the
/// pair list's column; empty when no wall law keeps a history.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WallHistory(pub(crate) Vec<HistoryColumn>);

/// The column of no wall: nothing stored.
static NO_COLUMN: HistoryColumn = HistoryColumn(None);

impl WallHistory {
    /// The column of wall `w` (an empty one where none is stored).
    pub fn column(&self, w: usize) -> &HistoryColumn {
        self.0.get(w).unwrap_or(&NO_COLUMN)
    }

    /// The column of wall `w` to write, of `walls` walls (the columns made as needed).
    pub(crate) fn column_mut(&mut self, w: usize, walls: usize) -> &mut HistoryColumn {
        if self.0.len() < walls.max(w + 1) {
            self.0.resize_with(walls.max(w + 1), HistoryColumn::default);
        }
        &mut self.0[w]
    }

    /// True when some wall's column is stored.
    pub fn is_stored(&self) -> bool {
        self.0.iter().any(HistoryColumn::is_stored)
    }

    /// The columns for a rebuilt list of wall pairs ([`HistoryColumn::remap`], no reversal: a
    /// wall pair has one grain).
    pub(crate) fn remap(&self, from: &[(u32, bool)]) -> WallHistory {
        WallHistory(self.0.iter().map(|c| c.remap(from)).collect())
    }

    /// Every stored entry as its encoding, wall by wall (nothing when none is stored).
    pub fn values(&self) -> Vec<f64> {
        self.0.iter().flat_map(|c| c.values()).collect()
    }
}

impl Serialize for WallHistory {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if !has_columns(WALL_COLUMNS_SINCE) {
            // (the layout of versions 2 and 3, for the compatibility tests: nothing)
            return s.serialize_unit();
        }
        self.0.serialize(s)
    }
}

impl<'de> Deserialize<'de> for WallHistory {
    fn deserialize<De: Deserializer<'de>>(d: De) -> Result<Self, De::Error> {
        if !has_columns(WALL_COLUMNS_SINCE) {
            return Ok(WallHistory::default());
        }
        Ok(WallHistory(Vec::<HistoryColumn>::deserialize(d)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A history of two values named `$name` (two laws with histories of the same shape).
    macro_rules! pair_history {
        ($t:ident, $name:literal) => {
            #[derive(Clone, Copy, Debug, Default, PartialEq)]
            struct $t(f64, f64);
            impl LawHistory for $t {
                const NAME: &'static str = $name;
                const WIDTH: usize = 2;
                type Lanes<R: crate::real::Real> = (R, R);
                fn to_lane(self) -> (f64, f64) {
                    (self.0, self.1)
                }
                fn from_lane(l: (f64, f64)) -> Self {
                    $t(l.0, l.1)
                }
                fn splat<R: crate::real::Real>(self) -> (R, R) {
                    (R::splat(self.0), R::splat(self.1))
                }
                fn gather<R: crate::real::Real>(mut at: impl FnMut(usize) -> Self) -> (R, R) {
                    let mut h = [(0.0, 0.0); 16];
                    for (l, x) in h.iter_mut().enumerate().take(R::LANES) {
                        let v = at(l);
                        *x = (v.0, v.1);
                    }
                    (R::from_fn(|l| h[l].0), R::from_fn(|l| h[l].1))
                }
                fn scatter<R: crate::real::Real>(lanes: (R, R), mut put: impl FnMut(usize, Self)) {
                    let mut h = [(0.0, 0.0); 16];
                    lanes.0.for_each_lane(|l, x| h[l].0 = x);
                    lanes.1.for_each_lane(|l, x| h[l].1 = x);
                    for (l, &(a, b)) in h.iter().enumerate().take(R::LANES) {
                        put(l, Self(a, b));
                    }
                }
                fn encode(&self, out: &mut Vec<f64>) {
                    out.extend([self.0, self.1]);
                }
                fn decode(v: &[f64]) -> Self {
                    $t(v[0], v[1])
                }
                fn reversed(self) -> Self {
                    $t(-self.0, self.1)
                }
            }
        };
    }
    pair_history!(Two, "two");
    pair_history!(TwoOther, "other");

    /// A column survives a serialize/deserialize round trip to the bit (as the encoding, typed
    /// again on first use), is remapped with reversal and defaults, and `()` stores nothing.
    #[test]
    fn columns_round_trip_and_remap() {
        let mut c = HistoryColumn::default();
        assert!(c.typed_mut::<()>(5).len() == 5 && !c.is_stored());
        let t = c.typed_mut::<Two>(3);
        t[0] = Two(1.0 / 3.0, -0.0);
        t[2] = Two(f64::MIN_POSITIVE, 7.5);
        let bytes = bincode::serialize(&c).unwrap();
        let mut back: HistoryColumn = bincode::deserialize(&bytes).unwrap();
        assert_eq!(back, c);
        let t = back.typed_mut::<Two>(3);
        assert_eq!(t[0].0.to_bits(), (1.0f64 / 3.0).to_bits());
        assert_eq!(t[0].1.to_bits(), (-0.0f64).to_bits());
        let mut r = back.remap(&[(2, true), (u32::MAX, false), (0, false)]);
        assert_eq!(r.typed_mut::<Two>(3), &[Two(-f64::MIN_POSITIVE, 7.5), Two::default(), Two(1.0 / 3.0, -0.0)]);
        // another law's column is not read as this one's
        assert_eq!(r.typed_mut::<TwoOther>(3), &[TwoOther::default(); 3]);
        // legacy layout: nothing read
        let empty = bincode::serialize(&0u8).unwrap();
        let legacy: HistoryColumn = decoding_version(2, || bincode::deserialize(&empty[..0]).unwrap());
        assert!(!legacy.is_stored());
    }
}
