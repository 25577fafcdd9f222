//! The instructions the neighbour-list loops and stage 1's lone filter need and `wide`
//! does not offer: the
//! left-pack (compress) of the slots a filter keeps (`vpcompressd` on AVX-512, a
//! permutation table on AVX2), and the fetch of 4-field records by 32-bit slot indices,
//! transposed into lanes (for 4 lanes a 256-bit load per slot and an AVX2 transpose; for
//! 8, a scalar load per field and lane on every instruction set, which measured as fast
//! on AMD's Zen 4 as AVX-512's transposes, and faster than a gather per field,
//! `_mm512_i32gather_pd`: `perf/README.md`, round four); and 1/sqrt without a divider
//! (`vrsqrt14pd` and Newton steps), which only the floor's bench runs; and the gather of
//! 8 words of a table by index (`vpgatherqq`), the lone filter's lookups. Each instruction
//! set is a token type implementing
//! [`Gathers`] that can only be made where its instructions run ([`Avx512`]: AVX-512F
//! and VL; [`Avx2`]; [`Portable`]: plain Rust, on every CPU), so its methods are safe:
//! every `unsafe` block here rests on the token's check and on the bounds its method
//! asserts. [`InstructionSet`] names them, is chosen at run time
//! ([`InstructionSet::detected`]) and runs a generic loop on the chosen token
//! ([`InstructionSet::run`]), so no CPU meets an instruction it lacks, and a machine
//! with AVX-512 tests all three paths. The project builds with `target-cpu=native`
//! (`.cargo/config.toml`), where the intrinsics inline into the loops; a build for a
//! baseline x86-64 still takes every path its host runs, correctly, with the intrinsics
//! called rather than inlined (slower: such a build is not what the benches measure).

/// An instruction set of the list loops and the lone filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InstructionSet {
    /// AVX-512F and AVX-512VL: the compress of 16 lanes (and AVX2's transposes).
    Avx512,
    /// AVX2: a table-driven left-pack, 4 x 4 transposes.
    Avx2,
    /// Plain Rust, lane by lane: every CPU.
    Portable,
}

impl InstructionSet {
    /// Every instruction set, the widest first.
    pub const ALL: [InstructionSet; 3] = [
        InstructionSet::Avx512,
        InstructionSet::Avx2,
        InstructionSet::Portable,
    ];

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            InstructionSet::Avx512 => "avx512",
            InstructionSet::Avx2 => "avx2",
            InstructionSet::Portable => "portable",
        }
    }

    /// The widest instruction set this CPU runs.
    pub fn detected() -> InstructionSet {
        Self::ALL
            .into_iter()
            .find(|isa| isa.is_available())
            .unwrap_or(InstructionSet::Portable)
    }

    /// The instruction set for lookups in a table of words (the lone filter's): the
    /// detected one, but the portable one's loads lane by lane where this CPU's gathers
    /// are microcoded and slower than loads, AMD's family 17h (Zen 1 and 2). On a Zen 1
    /// the in-place cell order of a scattered `large.fld` step took 0.92 ms on loads
    /// against 1.10 ms on gathers (`benches/step.rs`, `cell-order-in-place/...`).
    pub fn for_lookups() -> InstructionSet {
        // Asked once: CPUID leaves a virtual machine for its host.
        static LOOKUPS: std::sync::OnceLock<InstructionSet> = std::sync::OnceLock::new();
        *LOOKUPS.get_or_init(|| {
            #[cfg(target_arch = "x86_64")]
            if x86::gathers_are_microcoded() {
                return InstructionSet::Portable;
            }
            Self::detected()
        })
    }

    /// Whether this CPU runs it.
    pub fn is_available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            InstructionSet::Avx512 => Avx512::new().is_some(),
            #[cfg(target_arch = "x86_64")]
            InstructionSet::Avx2 => Avx2::new().is_some(),
            #[cfg(not(target_arch = "x86_64"))]
            InstructionSet::Avx512 | InstructionSet::Avx2 => false,
            InstructionSet::Portable => true,
        }
    }

    /// Runs `work` on this instruction set's token.
    ///
    /// # Panics
    /// If this CPU does not run it (see [`Self::is_available`]).
    pub(crate) fn run<W: OnInstructionSet>(self, work: W) -> W::Output {
        let unavailable = || -> ! { panic!("this CPU does not run {}", self.name()) };
        match self {
            #[cfg(target_arch = "x86_64")]
            InstructionSet::Avx512 => work.run(Avx512::new().unwrap_or_else(|| unavailable())),
            #[cfg(target_arch = "x86_64")]
            InstructionSet::Avx2 => work.run(Avx2::new().unwrap_or_else(|| unavailable())),
            #[cfg(not(target_arch = "x86_64"))]
            InstructionSet::Avx512 | InstructionSet::Avx2 => unavailable(),
            InstructionSet::Portable => work.run(Portable),
        }
    }
}

impl Default for InstructionSet {
    /// [`InstructionSet::detected`].
    fn default() -> Self {
        Self::detected()
    }
}

/// A loop generic over the instruction set it runs on.
pub(crate) trait OnInstructionSet {
    /// What the loop returns.
    type Output;
    /// Runs the loop with the instructions of `isa`.
    fn run<G: Gathers>(self, isa: G) -> Self::Output;
}

/// Eight slot indices, each checked below `bound` when made, so that fetches from any
/// array of at least `bound` records stay inside it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Slots {
    at: [u32; 8],
    bound: usize,
}

impl Slots {
    /// The slots `at`.
    ///
    /// # Panics
    /// If any is not below `bound`.
    #[inline(always)]
    pub(crate) fn new(at: [u32; 8], bound: usize) -> Slots {
        assert!(bound <= u32::MAX as usize);
        let below = at
            .iter()
            .fold(true, |all, &slot| all & (slot < bound as u32));
        assert!(below, "a slot index beyond its arrays");
        Slots { at, bound }
    }

    /// The indices.
    pub(crate) fn at(&self) -> [u32; 8] {
        self.at
    }
}

/// The left-pack, the 4-lane fetch of records, the reciprocal square root and the gather
/// of words, on one instruction set.
pub(crate) trait Gathers: Copy {
    /// Writes to the front of `out` `values[k]` for each bit k set in `kept`, in order,
    /// and returns how many (it may write anything to the 16 elements from there).
    ///
    /// # Panics
    /// If `out` is shorter than 16.
    fn left_pack(self, kept: u16, values: &[u32; 16], out: &mut [u32]) -> usize;
    /// The records of the first 4 slots of `at`, transposed: row f holds field f of each.
    fn records4(self, records: &[Record], at: &Slots) -> [[f64; 4]; 4];
    /// 1 / sqrt(x) of 8 positive lanes without a divider where the CPU allows (AVX-512's
    /// 14-bit `vrsqrt14pd` and two Newton steps, within 4 epsilon relative); elsewhere a
    /// rounded square root and a rounded division.
    fn reciprocal_sqrt8(self, x: [f64; 8]) -> [f64; 8];
    /// `words[at[k]]` for each of 8 indices: one gather on AVX-512, two on AVX2.
    ///
    /// # Panics
    /// If any index is not below `words.len()`.
    fn words8(self, words: &[u64], at: [u64; 8]) -> [u64; 8];
}

/// Panics unless every index of `at` is below `len`.
#[inline(always)]
fn check_words(len: usize, at: &[u64; 8]) {
    let below = at.iter().fold(true, |all, &k| all & (k < len as u64));
    assert!(below, "a word index beyond its array");
}

/// 1 / sqrt(x), lane by lane: a rounded square root, then a rounded division.
#[inline(always)]
fn reciprocal_sqrt_exact(x: [f64; 8]) -> [f64; 8] {
    x.map(|x| 1.0 / x.sqrt())
}

/// Four f64 fields of a slot kept together (a particle's position and density, say), so
/// that a loop fetches them with one load and a transpose instead of four gathers.
pub type Record = [f64; 4];

/// Panics unless `records` holds every slot of `at`.
#[inline(always)]
fn check_records(records: &[Record], at: &Slots) {
    assert!(records.len() >= at.bound, "gathering beyond an array");
}

/// The records at the first `N` slots of `at`, transposed, lane by lane: a scalar load
/// per field and lane. Every instruction set's 8-lane fetch: on AMD's Zen 4 it measured
/// faster than AVX-512's (four 256-bit loads with inserts, two rounds of shuffles) and
/// than gathers (`perf/README.md`, round four).
#[inline(always)]
pub(crate) fn fetch_records<const N: usize>(records: &[Record], at: &Slots) -> [[f64; N]; 4] {
    check_records(records, at);
    let rows: [Record; N] = std::array::from_fn(|k| records[at.at[k] as usize]);
    std::array::from_fn(|field| std::array::from_fn(|k| rows[k][field]))
}

/// Plain Rust, lane by lane.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Portable;

impl Gathers for Portable {
    #[inline(always)]
    fn left_pack(self, kept: u16, values: &[u32; 16], out: &mut [u32]) -> usize {
        let out = &mut out[..16];
        let mut count = 0;
        for (k, &value) in values.iter().enumerate() {
            // Written whether kept or not, the cursor advancing only past the kept: no
            // branch on the mask.
            out[count] = value;
            count += usize::from(kept >> k & 1);
        }
        count
    }

    #[inline(always)]
    fn records4(self, records: &[Record], at: &Slots) -> [[f64; 4]; 4] {
        fetch_records(records, at)
    }

    #[inline(always)]
    fn reciprocal_sqrt8(self, x: [f64; 8]) -> [f64; 8] {
        reciprocal_sqrt_exact(x)
    }

    #[inline(always)]
    fn words8(self, words: &[u64], at: [u64; 8]) -> [u64; 8] {
        at.map(|k| words[k as usize])
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use x86::{Avx2, Avx512};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{check_records, check_words, reciprocal_sqrt_exact, Gathers, Record, Slots};
    use std::arch::x86_64::*;

    /// Whether this is an AMD CPU of family 17h (Zen 1 and 2), whose gathers are
    /// microcoded: CPUID's vendor, and its family (base plus extended).
    pub(crate) fn gathers_are_microcoded() -> bool {
        let vendor = __cpuid(0);
        let amd = [vendor.ebx, vendor.edx, vendor.ecx]
            .map(u32::to_le_bytes)
            .concat()
            == b"AuthenticAMD";
        let signature = __cpuid(1).eax;
        let base = (signature >> 8) & 0xf;
        let family = if base == 0xf {
            base + ((signature >> 20) & 0xff)
        } else {
            base
        };
        amd && family == 0x17
    }

    /// AVX-512F and AVX-512VL (and AVX2), checked at run time.
    #[derive(Debug, Clone, Copy)]
    pub(crate) struct Avx512(());

    impl Avx512 {
        /// The token, where this CPU runs these instructions.
        pub(crate) fn new() -> Option<Avx512> {
            let runs = is_x86_feature_detected!("avx512f")
                && is_x86_feature_detected!("avx512vl")
                && is_x86_feature_detected!("avx2");
            runs.then_some(Avx512(()))
        }
    }

    /// AVX2, checked at run time.
    #[derive(Debug, Clone, Copy)]
    pub(crate) struct Avx2(());

    impl Avx2 {
        /// The token, where this CPU runs these instructions.
        pub(crate) fn new() -> Option<Avx2> {
            is_x86_feature_detected!("avx2").then_some(Avx2(()))
        }
    }

    /// A record as a register.
    ///
    /// # Safety
    /// AVX runs on this CPU.
    #[inline(always)]
    unsafe fn load_record(record: &Record) -> __m256d {
        // SAFETY: an unaligned load of 4 f64 from a record of 4; AVX is the caller's.
        unsafe { _mm256_loadu_pd(record.as_ptr()) }
    }

    /// The 4 records at the first 4 slots of `at`, transposed with AVX2.
    ///
    /// # Safety
    /// AVX2 runs on this CPU.
    #[inline(always)]
    unsafe fn records4_avx2(records: &[Record], at: &Slots) -> [__m256d; 4] {
        check_records(records, at);
        let record = |k: usize| &records[at.at()[k] as usize];
        // SAFETY: AVX2 is the caller's; the records are in bounds (indexed).
        unsafe {
            let [r0, r1, r2, r3] = [0, 1, 2, 3].map(|k| load_record(record(k)));
            transpose4([r0, r1, r2, r3])
        }
    }

    /// The transpose of 4 rows of 4 f64.
    ///
    /// # Safety
    /// AVX runs on this CPU.
    #[inline(always)]
    unsafe fn transpose4([r0, r1, r2, r3]: [__m256d; 4]) -> [__m256d; 4] {
        // SAFETY: register operations; AVX is the caller's.
        unsafe {
            let (t0, t1) = (_mm256_unpacklo_pd(r0, r1), _mm256_unpackhi_pd(r0, r1));
            let (t2, t3) = (_mm256_unpacklo_pd(r2, r3), _mm256_unpackhi_pd(r2, r3));
            [
                _mm256_permute2f128_pd::<0x20>(t0, t2),
                _mm256_permute2f128_pd::<0x20>(t1, t3),
                _mm256_permute2f128_pd::<0x31>(t0, t2),
                _mm256_permute2f128_pd::<0x31>(t1, t3),
            ]
        }
    }

    impl Gathers for Avx512 {
        #[inline(always)]
        fn records4(self, records: &[Record], at: &Slots) -> [[f64; 4]; 4] {
            // SAFETY: the token exists only where AVX2 runs.
            unsafe { std::mem::transmute(records4_avx2(records, at)) }
        }

        #[inline(always)]
        fn left_pack(self, kept: u16, values: &[u32; 16], out: &mut [u32]) -> usize {
            let out = &mut out[..16];
            // SAFETY: the token exists only where AVX-512F runs; the load reads the 16
            // u32 of `values`, the store writes 16 u32 into `out`, which holds 16.
            // Compressed in a register, then stored whole: a compress straight to memory
            // is several times slower on AMD's Zen 4.
            unsafe {
                let values = _mm512_loadu_si512(values.as_ptr().cast());
                let packed = _mm512_maskz_compress_epi32(kept, values);
                _mm512_storeu_si512(out.as_mut_ptr().cast(), packed);
            }
            kept.count_ones() as usize
        }

        #[inline(always)]
        fn reciprocal_sqrt8(self, x: [f64; 8]) -> [f64; 8] {
            let mut out = [0.0; 8];
            // SAFETY: the token exists only where AVX-512F runs; the load reads the 8 f64
            // of `x`, the store writes the 8 of `out`.
            unsafe {
                let x = _mm512_loadu_pd(x.as_ptr());
                let half_x = _mm512_mul_pd(x, _mm512_set1_pd(0.5));
                let three_halves = _mm512_set1_pd(1.5);
                // Newton's step for 1/sqrt: y (3/2 - x/2 y^2), each doubling the bits.
                let mut y = _mm512_rsqrt14_pd(x);
                for _ in 0..2 {
                    let y2 = _mm512_mul_pd(y, y);
                    y = _mm512_mul_pd(y, _mm512_fnmadd_pd(half_x, y2, three_halves));
                }
                _mm512_storeu_pd(out.as_mut_ptr(), y);
            }
            out
        }

        #[inline(always)]
        fn words8(self, words: &[u64], at: [u64; 8]) -> [u64; 8] {
            check_words(words.len(), &at);
            let mut out = [0; 8];
            // SAFETY: the token exists only where AVX-512F runs; the load reads the 8 u64
            // of `at`, the gather reads `words` at each of them (checked below its length,
            // scale 8 bytes per word), the store writes the 8 of `out`.
            unsafe {
                let at = _mm512_loadu_si512(at.as_ptr().cast());
                let gathered = _mm512_i64gather_epi64::<8>(at, words.as_ptr().cast());
                _mm512_storeu_si512(out.as_mut_ptr().cast(), gathered);
            }
            out
        }
    }

    /// For each 8-bit mask, the lanes of its set bits in order, then zeros: AVX2's
    /// left-pack is a permutation by this table.
    static LEFT_PACK: [[u32; 8]; 256] = {
        let mut table = [[0; 8]; 256];
        let mut mask = 0;
        while mask < 256 {
            let (mut lane, mut count) = (0, 0);
            while lane < 8 {
                if mask >> lane & 1 != 0 {
                    table[mask][count] = lane as u32;
                    count += 1;
                }
                lane += 1;
            }
            mask += 1;
        }
        table
    };

    impl Gathers for Avx2 {
        #[inline(always)]
        fn left_pack(self, kept: u16, values: &[u32; 16], out: &mut [u32]) -> usize {
            let out = &mut out[..16];
            let [low, high] = kept.to_le_bytes();
            let low_count = low.count_ones() as usize;
            // SAFETY: the token exists only where AVX2 runs; the loads read the table's
            // rows of 8 u32 and the halves of `values`' 16, the stores write 8 u32 each
            // into `out` from 0 and from `low_count` <= 8, which `out`'s 16 hold.
            unsafe {
                for (half, mask, at) in [(0, low, 0), (8, high, low_count)] {
                    let order = _mm256_loadu_si256(LEFT_PACK[usize::from(mask)].as_ptr().cast());
                    let half = _mm256_loadu_si256(values[half..].as_ptr().cast());
                    let packed = _mm256_permutevar8x32_epi32(half, order);
                    _mm256_storeu_si256(out[at..].as_mut_ptr().cast(), packed);
                }
            }
            kept.count_ones() as usize
        }

        #[inline(always)]
        fn records4(self, records: &[Record], at: &Slots) -> [[f64; 4]; 4] {
            // SAFETY: the token exists only where AVX2 runs.
            unsafe { std::mem::transmute(records4_avx2(records, at)) }
        }

        /// AVX2 has no f64 reciprocal square root: a square root and a division.
        #[inline(always)]
        fn reciprocal_sqrt8(self, x: [f64; 8]) -> [f64; 8] {
            reciprocal_sqrt_exact(x)
        }

        #[inline(always)]
        fn words8(self, words: &[u64], at: [u64; 8]) -> [u64; 8] {
            check_words(words.len(), &at);
            let mut out = [0; 8];
            // SAFETY: the token exists only where AVX2 runs; the loads read the halves of
            // `at`'s 8 u64, the gathers read `words` at each of them (checked below its
            // length, scale 8 bytes per word), the stores write the halves of `out`.
            unsafe {
                for half in [0, 4] {
                    let at = _mm256_loadu_si256(at[half..].as_ptr().cast());
                    let base = words.as_ptr().cast();
                    let gathered = _mm256_i64gather_epi64::<8>(base, at);
                    _mm256_storeu_si256(out[half..].as_mut_ptr().cast(), gathered);
                }
            }
            out
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs the checks on one instruction set.
    struct Check;

    impl OnInstructionSet for Check {
        type Output = ();
        fn run<G: Gathers>(self, isa: G) {
            // Records, a repeated slot (17) among them.
            let at = Slots::new([3, 39, 0, 17, 17, 8, 21, 5], 40);
            let records: Vec<Record> = (0..40)
                .map(|k| [k as f64, k as f64 + 0.25, -(k as f64), 100.0 + k as f64])
                .collect();
            let fields8 = super::fetch_records::<8>(&records, &at);
            let fields4 = isa.records4(&records, &at);
            for field in 0..4 {
                for k in 0..8 {
                    let expected = records[at.at()[k] as usize][field];
                    assert_eq!(fields8[field][k], expected);
                    if k < 4 {
                        assert_eq!(fields4[field][k], expected);
                    }
                }
            }
            let values: [u32; 16] = std::array::from_fn(|k| 7 * k as u32 + 100);
            for kept in 0..=u16::MAX {
                let mut out = [u32::MAX; 17];
                let count = isa.left_pack(kept, &values, &mut out);
                let expected: Vec<u32> = (0..16)
                    .filter(|k| kept >> k & 1 != 0)
                    .map(|k| values[k])
                    .collect();
                assert_eq!(count, expected.len());
                let packed = &out[..count];
                assert_eq!(packed, expected, "mask {kept:016b}");
                assert_eq!(out[16], u32::MAX, "nothing written past 16");
            }
            // Words by index, repeated and at both ends.
            let words: Vec<u64> = (0..40u64).map(|k| k * k * 0x9e37_79b9 + 7).collect();
            let at = [3, 39, 0, 17, 17, 8, 21, 5];
            assert_eq!(isa.words8(&words, at), at.map(|k| words[k as usize]));
            // 1 / sqrt over 30 decades, within 4 units in the last place of the exact.
            for decade in -20..10 {
                let x: [f64; 8] =
                    std::array::from_fn(|k| (1.0 + 0.37 * k as f64) * 10f64.powi(decade));
                let y = isa.reciprocal_sqrt8(x);
                for (x, y) in x.into_iter().zip(y) {
                    let exact = 1.0 / x.sqrt();
                    assert!((y - exact).abs() <= 4.0 * f64::EPSILON * exact, "{x}: {y}");
                }
            }
        }
    }

    #[test]
    fn every_available_instruction_set_fetches_packs_gathers_and_takes_reciprocal_roots_alike() {
        let mut ran = 0;
        for isa in InstructionSet::ALL {
            if isa.is_available() {
                isa.run(Check);
                ran += 1;
            } else {
                println!("{} not run: this CPU lacks it", isa.name());
            }
        }
        assert!(ran >= 1);
        assert!(InstructionSet::detected().is_available());
        assert!(InstructionSet::Portable.is_available());
    }

    #[test]
    fn lookups_run_on_an_available_set_and_on_loads_only_where_gathers_are_microcoded() {
        let lookups = InstructionSet::for_lookups();
        assert!(lookups.is_available());
        #[cfg(target_arch = "x86_64")]
        {
            let expected = match x86::gathers_are_microcoded() {
                true => InstructionSet::Portable,
                false => InstructionSet::detected(),
            };
            assert_eq!(lookups, expected);
            // This CPU's own answer, from /proc/cpuinfo where Linux gives it.
            if let Ok(info) = std::fs::read_to_string("/proc/cpuinfo") {
                let field = |name: &str| {
                    info.lines()
                        .find(|line| line.starts_with(name))
                        .and_then(|line| line.split(':').nth(1))
                        .map(|value| value.trim().to_string())
                };
                let zen12 = field("vendor_id").as_deref() == Some("AuthenticAMD")
                    && field("cpu family").as_deref() == Some("23");
                assert_eq!(x86::gathers_are_microcoded(), zen12);
            }
        }
    }

    #[test]
    #[should_panic(expected = "beyond its arrays")]
    fn a_slot_beyond_the_bound_is_refused() {
        Slots::new([0, 1, 2, 3, 4, 5, 6, 8], 8);
    }

    #[test]
    fn a_fetch_from_a_shorter_array_is_refused_on_every_instruction_set() {
        for isa in InstructionSet::ALL
            .into_iter()
            .filter(|isa| isa.is_available())
        {
            let fetch = std::panic::catch_unwind(|| isa.run(FetchFrom(&[[1.0; 4]; 8])));
            assert!(fetch.is_err(), "{}", isa.name());
        }
    }

    #[test]
    fn a_word_index_beyond_the_array_is_refused_on_every_instruction_set() {
        for isa in InstructionSet::ALL
            .into_iter()
            .filter(|isa| isa.is_available())
        {
            let gather = std::panic::catch_unwind(|| isa.run(WordsFrom(&[1; 8], 8)));
            assert!(gather.is_err(), "{}", isa.name());
            assert_eq!(isa.run(WordsFrom(&[1; 8], 7)), [1; 8], "{}", isa.name());
        }
    }

    /// Words gathered at index `.1` (and 0) from `.0`.
    struct WordsFrom<'a>(&'a [u64], u64);

    impl OnInstructionSet for WordsFrom<'_> {
        type Output = [u64; 8];
        fn run<G: Gathers>(self, isa: G) -> [u64; 8] {
            isa.words8(self.0, [0, 0, 0, self.1, 0, 0, 0, 0])
        }
    }

    /// Records fetched from an array shorter than the slots' bound.
    struct FetchFrom<'a>(&'a [Record]);

    impl OnInstructionSet for FetchFrom<'_> {
        type Output = [[f64; 4]; 4];
        fn run<G: Gathers>(self, isa: G) -> [[f64; 4]; 4] {
            isa.records4(self.0, &Slots::new([0; 8], 16))
        }
    }
}
