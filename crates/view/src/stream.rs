//! Streaming playback of a baked asset (paper A §6): while frame `k` renders, a background
//! thread reads frames `k+1..k+n` from the memory-mapped `.haze` file — RBF array and the
//! hash volume holding the frame's residual — so the renderer never waits on I/O or
//! decoding.
//!
//! In playback the residual is decoded frame by frame on a thread of its own
//! ([`haze_hash::block::decode_frames`]): a hash volume's values are coded frame after
//! frame, so each frame is handed over, as a group of its own, as soon as the volume's
//! value streams have passed it, and the thread goes on into the next volume (after the
//! last frame, the first again when looping). A volume's decode is thus spread over its
//! frames: playback never waits for a whole volume, at its start, after a seek or at a
//! volume's first frame. Memory is bounded whatever the sequence length: at most `ahead`
//! decoded frames wait in the stream's queue, one more in the residual thread's, one is
//! being decoded and one is held by the caller — each frame's own bricks, not a volume's —
//! and the frames decoded are kept for a later round while they fit in 128 MiB (the size
//! of a hash volume at the bake's default `--volume-mib`), so that a short loop, a seek
//! back, or a renderer slower than the frame rate skipping round a short loop, decode
//! each frame once; a longer sequence is decoded as it plays.
//! Scrubbing ([`FrameStream::seek`]) restarts the reader at the new frame and discards
//! what it had read ahead; the residual thread starts again at the frame's volume, its
//! earlier frames decoded but not packed. A damaged block is reported on its frame, with
//! the file and the block named, and playback goes on.
//!
//! A decoder that does not decode ahead ([`FrameDecoder::new`]: `haze render --frame`,
//! `haze export`, a scene's medium) decodes a volume up to the frame asked for, and
//! whole when a later frame of it is asked for; its frames share that group.
//!
//! A packed asset's frame (`haze pack`: a raw volume) plays as a frame with no RBFs and
//! the whole density as a lossless residual, hashed as it is read (tens of ms a frame).

use haze_asset::{Asset, AssetError, BlockKind, Scope, decode_raw_volume, decode_rbfs};
use haze_hash::tile::{DEFAULT_BRICK, ResidualGroup};
use haze_hash::{BuildOptions, QuantOptions, quantize};
use haze_volume::{Bbox, Rbf};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// The residual of one frame: its slot in a shared hash volume.
#[derive(Clone, Debug)]
pub struct ResidualSlot {
    pub group: Arc<ResidualGroup>,
    /// The frame's index within the hash volume (0..27).
    pub slot: usize,
}

impl ResidualSlot {
    /// The dequantized residual at voxel `p`.
    pub fn lookup(&self, p: [u32; 3]) -> f32 {
        self.group.lookup(self.slot, p)
    }

    /// The dequantized residual at every voxel (x fastest), as the volume pass takes it.
    pub fn dense(&self) -> Vec<f32> {
        self.group.dense(self.slot)
    }
}

/// One decoded frame.
#[derive(Clone, Debug)]
pub struct StreamFrame {
    /// Position in the asset (0-based).
    pub index: usize,
    /// The source frame number.
    pub number: i64,
    pub rbfs: Vec<Rbf>,
    /// `None` when the asset stores no residual (baked without one).
    pub residual: Option<ResidualSlot>,
}

/// What a decoder that does not decode ahead holds of one hash volume: block `block`'s
/// first frames, as many as `group` holds (up to the volume's last).
#[derive(Debug)]
struct Held {
    block: usize,
    group: Arc<ResidualGroup>,
}

impl Held {
    /// Slot `slot` of block `block`, if held.
    fn slot(&self, block: usize, slot: usize) -> Option<ResidualSlot> {
        (block == self.block && slot < self.group.frames()).then(|| ResidualSlot {
            group: self.group.clone(),
            slot,
        })
    }
}

/// Playback's decoded residual frames kept for later — a loop's next round, a seek back, a
/// renderer slower than the frame rate that skips round a short loop — as long as they fit
/// in [`KEPT_BYTES`]. None is let go: a loop longer than the budget still finds its first
/// frames each round (a least-recently-used cache would let each frame go just before it
/// came round again), and a sequence longer than it is decoded as it plays.
#[derive(Debug, Default)]
struct Kept {
    frames: HashMap<(usize, usize), Arc<ResidualGroup>>,
    bytes: usize,
}

/// Decoded residual frames a player keeps at most: a hash volume's size at the bake's
/// default `--volume-mib`, so a volume of a default bake is decoded once however it loops.
const KEPT_BYTES: usize = 128 << 20;

impl Kept {
    /// Keeps frame `at` (block, slot) if it fits.
    fn keep(&mut self, at: (usize, usize), g: &Arc<ResidualGroup>) {
        let bytes = g.bytes();
        if self.bytes + bytes <= KEPT_BYTES && self.frames.insert(at, g.clone()).is_none() {
            self.bytes += bytes;
        }
    }
}

/// A frame's residual decoded ahead: its block, its slot and the frame as a group of its
/// own (or the one-line error met there).
type Decoded = (usize, usize, Result<ResidualGroup, AssetError>);

/// Playback's residual frames, decoded in order by a thread of their own one frame at a
/// time ([`haze_hash::block::decode_frames`]), from one hash volume into the next, at most
/// [`AHEAD_FRAMES`] waiting.
#[derive(Debug)]
struct Ahead {
    frames: Receiver<Decoded>,
    /// A frame received that was not the one asked for (it comes later).
    held: Option<Decoded>,
    /// Set when the frames are no longer wanted, so that the thread stops even while it
    /// passes over a volume's first frames (sending nothing) after a seek.
    gone: Arc<AtomicBool>,
}

impl Drop for Ahead {
    fn drop(&mut self) {
        self.gone.store(true, Ordering::Release);
    }
}

/// Residual frames playback's decode thread keeps ready (besides the one it decodes): the
/// stream's own queue lies after it.
const AHEAD_FRAMES: usize = 1;

/// Reads frames out of an asset: one at a time, a hash volume held while its frames are
/// asked for ([`FrameDecoder::new`]), or in playback frame after frame on a thread of
/// its own, the frames decoded kept ([`FrameDecoder::prefetching`]).
#[derive(Debug)]
pub struct FrameDecoder {
    asset: Arc<Asset>,
    /// The hash volume last decoded (a decoder that does not decode ahead).
    cached: Option<Held>,
    /// Playback's frames kept for later.
    kept: Kept,
    /// Whether to decode frames ahead in order on a thread (playback).
    prefetch: bool,
    /// Whether the frame after the last is the first again (looping playback).
    wrap: bool,
    ahead: Option<Ahead>,
}

impl FrameDecoder {
    /// A decoder that decodes what it is asked for (single frames, exports, a scene's
    /// medium, Python's reader).
    pub fn new(asset: Arc<Asset>) -> FrameDecoder {
        FrameDecoder {
            asset,
            cached: None,
            kept: Kept::default(),
            prefetch: false,
            wrap: false,
            ahead: None,
        }
    }

    /// A decoder for playback in order: a thread of its own decodes the residual frame by
    /// frame ahead of the frames asked for, from one hash volume into the next (after the
    /// last frame, the first again when `looping`), each frame a group of its own.
    pub fn prefetching(asset: Arc<Asset>, looping: bool) -> FrameDecoder {
        FrameDecoder {
            prefetch: true,
            wrap: looping,
            ..FrameDecoder::new(asset)
        }
    }

    pub fn asset(&self) -> &Asset {
        &self.asset
    }

    /// Whether a thread decodes residual frames ahead (playback, while frames follow).
    pub fn decoding_ahead(&self) -> bool {
        self.ahead.is_some()
    }

    /// Frame `k`: its RBFs and residual slot, blocks verified.
    pub fn decode(&mut self, k: usize) -> Result<StreamFrame, AssetError> {
        let asset = self.asset.clone();
        let a = &*asset;
        let number =
            *a.header()
                .source
                .frame_numbers
                .get(k)
                .ok_or_else(|| AssetError::NoFrame {
                    path: a.path().to_path_buf(),
                    frame: k,
                    count: a.frame_count(),
                })?;
        let covering = |kind: BlockKind| block_of(a, kind, k);
        let Some(rbf_index) = covering(BlockKind::Rbfs) else {
            return match covering(BlockKind::RawVolume) {
                Some(i) => self.decode_raw(k, number, i),
                None => Err(AssetError::Invalid {
                    path: a.path().to_path_buf(),
                    what: format!("frame {number} has neither RBFs nor a raw volume"),
                }),
            };
        };
        let block = a.block(rbf_index)?;
        let rbfs = decode_rbfs(block.bytes).map_err(|e| a.block_error(&block, e))?;
        let residual = match covering(BlockKind::ResidualHash) {
            None => None,
            Some(i) => {
                let entry = &a.entries()[i];
                let Scope::Frames { first, .. } = entry.scope else {
                    unreachable!("block_of() excludes asset-wide blocks")
                };
                Some(self.residual(i, k - first as usize)?)
            }
        };
        Ok(StreamFrame {
            index: k,
            number,
            rbfs,
            residual,
        })
    }
}

impl FrameDecoder {
    /// Slot `slot` of hash volume `i` (a block index). In playback: kept ([`Kept`]) or
    /// decoded ahead ([`Ahead`]), a frame of its own. Otherwise held or decoded now: a
    /// volume met is decoded only up to `slot` (a single frame's render and a seek need
    /// not wait for the volume's later frames), and whole when a later frame of it is
    /// asked for: at most two decodes a volume.
    fn residual(&mut self, i: usize, slot: usize) -> Result<ResidualSlot, AssetError> {
        if self.prefetch {
            let group = match self.kept.frames.get(&(i, slot)) {
                Some(g) => g.clone(),
                None => {
                    let g = Arc::new(self.decoded_ahead(i, slot)?);
                    self.kept.keep((i, slot), &g);
                    g
                }
            };
            return Ok(ResidualSlot { group, slot: 0 });
        }
        if let Some(r) = self.cached.as_ref().and_then(|h| h.slot(i, slot)) {
            return Ok(r);
        }
        let partial = self.cached.as_ref().is_some_and(|h| h.block == i);
        let through = if partial { usize::MAX } else { slot };
        let held = Held {
            block: i,
            group: Arc::new(decode_group(&self.asset, i, through)?),
        };
        let r = held.slot(i, slot);
        self.cached = Some(held);
        Ok(r.expect("a decoded group holds the slot asked for"))
    }

    /// Slot `slot` of hash volume `i` from the thread decoding ahead, which is started
    /// there again when it is elsewhere (a seek, the first frame, a damaged block met).
    fn decoded_ahead(&mut self, i: usize, slot: usize) -> Result<ResidualGroup, AssetError> {
        if let Some(g) = self.take_ahead(i, slot) {
            return g;
        }
        let (tx, rx) = sync_channel(AHEAD_FRAMES);
        let (asset, wrap) = (self.asset.clone(), self.wrap);
        let gone = Arc::new(AtomicBool::new(false));
        let stop = gone.clone();
        let started = std::thread::Builder::new()
            .name("haze-residual".into())
            .spawn(move || decode_ahead(&asset, (i, slot), wrap, &tx, &stop));
        let path = self.asset.path().to_path_buf();
        let failed = |what: String| AssetError::Invalid {
            path: path.clone(),
            what,
        };
        started.map_err(|e| failed(format!("cannot start the residual's thread: {e}")))?;
        self.ahead = Some(Ahead {
            frames: rx,
            held: None,
            gone,
        });
        self.take_ahead(i, slot)
            .unwrap_or_else(|| Err(failed(format!("the thread decoding block {i} failed"))))
    }

    /// Slot `slot` of volume `i` if the thread decoding ahead gives it next (the frames
    /// before it in the volume passed over); `None`, the frame it gives kept, when it is
    /// past that slot or in another volume, or has ended.
    fn take_ahead(&mut self, i: usize, slot: usize) -> Option<Result<ResidualGroup, AssetError>> {
        let ahead = self.ahead.as_mut()?;
        loop {
            let next = match ahead.held.take() {
                Some(d) => d,
                None => match ahead.frames.recv() {
                    Ok(d) => d,
                    Err(_) => {
                        self.ahead = None;
                        return None;
                    }
                },
            };
            match (next.0 == i, next.1.cmp(&slot)) {
                (true, std::cmp::Ordering::Equal) => return Some(next.2),
                (true, std::cmp::Ordering::Less) => {
                    // Passed over (a skip ahead), kept for a later round.
                    if let Ok(g) = next.2 {
                        self.kept.keep((next.0, next.1), &Arc::new(g));
                    }
                }
                _ => {
                    ahead.held = Some(next);
                    return None;
                }
            }
        }
    }

    /// Frame `k` (number `number`) of a packed asset, from its raw-volume block `block`: no
    /// RBFs and the whole density as a lossless residual (its `f32` values in a hash
    /// volume of its own), so every renderer plays it as it was packed.
    fn decode_raw(
        &mut self,
        k: usize,
        number: i64,
        block: usize,
    ) -> Result<StreamFrame, AssetError> {
        let a = &*self.asset;
        let block = a.block(block)?;
        let view = decode_raw_volume(block.bytes).map_err(|e| a.block_error(&block, e))?;
        let dims = a.header().grid.dims;
        if view.dims != dims.map(|d| d as usize) {
            return Err(a.block_error(
                &block,
                format!(
                    "frame {number}'s volume is {:?}, the grid {dims:?}",
                    view.dims
                ),
            ));
        }
        let peak = view.data.iter().copied().fold(0.0f32, f32::max);
        let lossless = QuantOptions {
            error: 0.0,
            ..QuantOptions::default()
        };
        let group = quantize(&view.data, peak, lossless)
            .map_err(|e| a.block_error(&block, format!("frame {number}: {e}")))
            .and_then(|q| {
                ResidualGroup::build(dims, DEFAULT_BRICK, &[q], BuildOptions::default())
                    .map_err(|e| a.block_error(&block, format!("frame {number}: {e}")))
            })?;
        Ok(StreamFrame {
            index: k,
            number,
            rbfs: Vec::new(),
            residual: Some(ResidualSlot {
                group: Arc::new(group),
                slot: 0,
            }),
        })
    }
}

/// Hash volume `i` of `a` (a block index), its checksum verified, decoded into the GPU's
/// tables: its frames up to slot `through` ([`haze_hash::block::decode_through`]).
fn decode_group(a: &Asset, i: usize, through: usize) -> Result<ResidualGroup, AssetError> {
    let block = a.block(i)?;
    let g = haze_hash::block::decode_through(block.bytes, through)
        .map_err(|e| a.block_error(&block, e))?;
    if g.dims != a.header().grid.dims {
        return Err(a.block_error(&block, "residual dims differ from the grid's"));
    }
    Ok(g)
}

/// The block (its index) of kind `kind` that holds frame `k`, if any.
fn block_of(a: &Asset, kind: BlockKind, k: usize) -> Option<usize> {
    a.entries()
        .iter()
        .position(|e| e.kind == kind && e.scope.covers(k as u32) && e.scope != Scope::Asset)
}

/// Playback's residual thread: decodes hash volume `i` frame by frame from slot `from`,
/// then the volume of the frame after its last (frame 0 after the asset's last when
/// `wrap`), and so on, sending each frame to `tx` as a group of its own. Ends when the
/// frames are no longer wanted (`gone`, or the receiver gone), at the end of a sequence
/// that does not wrap, at a frame with no residual, or after sending the error met at a
/// frame.
fn decode_ahead(
    a: &Asset,
    (mut i, mut from): (usize, usize),
    wrap: bool,
    tx: &SyncSender<Decoded>,
    gone: &AtomicBool,
) {
    loop {
        let mut next = from;
        let mut ended = false;
        let decoded = a.block(i).and_then(|block| {
            haze_hash::block::decode_frames(block.bytes, from, |j, g| {
                ended = gone.load(Ordering::Acquire);
                let Some(g) = g.filter(|_| !ended) else {
                    return !ended;
                };
                next = j + 1;
                let g = if g.dims == a.header().grid.dims {
                    Ok(g)
                } else {
                    Err(a.block_error(&block, "residual dims differ from the grid's"))
                };
                ended = g.is_err();
                ended |= tx.send((i, j, g)).is_err();
                !ended
            })
            .map_err(|e| a.block_error(&block, e))
        });
        if ended {
            return;
        }
        if let Err(e) = decoded {
            let _ = tx.send((i, next, Err(e)));
            return;
        }
        let Scope::Frames { first, count } = a.entries()[i].scope else {
            return;
        };
        let mut after = first as usize + count as usize;
        if after >= a.frame_count() {
            if !wrap {
                return;
            }
            after = 0;
        }
        let Some(j) = block_of(a, BlockKind::ResidualHash, after) else {
            return;
        };
        (i, from) = (j, 0);
    }
}

/// What the reader thread is asked to do.
#[derive(Debug, Default)]
struct Control {
    /// Bumped by every seek; frames read for an older generation are discarded.
    generation: AtomicU64,
    /// Where the current generation starts.
    start: Mutex<usize>,
    stop: AtomicBool,
    /// Frames decoded so far (for tests and statistics).
    decoded: AtomicUsize,
}

/// A frame (or its one-line error) for a generation; `None` marks the end of the
/// sequence when not looping.
type Message = (u64, Option<Result<StreamFrame, String>>);

/// Background reading of an asset's frames, in order from a start frame, `ahead` frames in
/// advance, wrapping to frame 0 after the last when `looping`.
#[derive(Debug)]
pub struct FrameStream {
    path: PathBuf,
    frame_count: usize,
    numbers: Vec<i64>,
    dims: [usize; 3],
    bbox: Bbox,
    control: Arc<Control>,
    frames: Option<Receiver<Message>>,
    reader: Option<JoinHandle<()>>,
}

impl FrameStream {
    /// Opens `path` (header and index verified) and starts reading at frame 0.
    pub fn open(path: &Path, ahead: usize, looping: bool) -> Result<FrameStream, AssetError> {
        let asset = Arc::new(Asset::open(path)?);
        let frame_count = asset.frame_count();
        if frame_count == 0 {
            return Err(AssetError::Invalid {
                path: path.to_path_buf(),
                what: "the asset has no frames".into(),
            });
        }
        let numbers = asset.header().source.frame_numbers.clone();
        let grid = &asset.header().grid;
        let dims = grid.dims.map(|d| d as usize);
        let bbox = Bbox::new(grid.bbox_min, grid.bbox_max);
        let control = Arc::new(Control::default());
        let (tx, rx) = sync_channel(ahead.max(1));
        let c = control.clone();
        let reader = std::thread::Builder::new()
            .name("haze-stream".into())
            .spawn(move || read_frames(FrameDecoder::prefetching(asset, looping), tx, &c, looping))
            .map_err(|e| AssetError::Invalid {
                path: path.to_path_buf(),
                what: format!("cannot start the reader thread: {e}"),
            })?;
        Ok(FrameStream {
            path: path.to_path_buf(),
            frame_count,
            numbers,
            dims,
            bbox,
            control,
            frames: Some(rx),
            reader: Some(reader),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn frame_count(&self) -> usize {
        self.frame_count
    }

    /// The source frame number of each frame, in order.
    pub fn frame_numbers(&self) -> &[i64] {
        &self.numbers
    }

    /// The voxel grid every frame is rendered on.
    pub fn grid(&self) -> ([usize; 3], Bbox) {
        (self.dims, self.bbox)
    }

    /// Frames decoded by the reader so far.
    pub fn decoded(&self) -> usize {
        self.control.decoded.load(Ordering::Acquire)
    }

    /// Restarts reading at frame `k` (clamped to the asset); frames read ahead are dropped.
    ///
    /// The queue is not drained here: the reader may already have queued frames of the
    /// new start, which a drain would lose. The stale frames are dropped as they are
    /// received ([`FrameStream::next_frame`] compares generations), which also frees a
    /// reader blocked on the full queue.
    pub fn seek(&mut self, k: usize) {
        *self.control.start.lock().unwrap_or_else(|e| e.into_inner()) = k.min(self.frame_count - 1);
        self.control.generation.fetch_add(1, Ordering::AcqRel);
    }

    /// The next frame, waiting for it; `None` after the last frame when not looping.
    pub fn next_frame(&mut self) -> Option<Result<StreamFrame, String>> {
        let rx = self.frames.as_ref()?;
        loop {
            let (generation, frame) = rx.recv().ok()?;
            if generation == self.control.generation.load(Ordering::Acquire) {
                return frame;
            }
        }
    }

    /// The next frame if it is ready, without waiting (a playback loop that finds none
    /// has caught up with the reader; the end of a non-looping sequence also gives
    /// `None`).
    pub fn try_next_frame(&mut self) -> Option<Result<StreamFrame, String>> {
        let rx = self.frames.as_ref()?;
        while let Ok((generation, frame)) = rx.try_recv() {
            if generation == self.control.generation.load(Ordering::Acquire) {
                return frame;
            }
        }
        None
    }
}

impl Drop for FrameStream {
    fn drop(&mut self) {
        self.control.stop.store(true, Ordering::Release);
        // Dropping the receiver makes a blocked send fail, so the reader exits.
        self.frames = None;
        if let Some(h) = self.reader.take() {
            let _ = h.join();
        }
    }
}

/// The reader thread: decodes frames in order and queues them, restarting on a seek.
fn read_frames(mut dec: FrameDecoder, tx: SyncSender<Message>, c: &Control, looping: bool) {
    let count = dec.asset().frame_count();
    let mut generation = c.generation.load(Ordering::Acquire);
    let mut k = 0usize;
    loop {
        if c.stop.load(Ordering::Acquire) {
            return;
        }
        let now = c.generation.load(Ordering::Acquire);
        if now != generation {
            generation = now;
            k = *c.start.lock().unwrap_or_else(|e| e.into_inner());
        }
        if k == count && looping {
            k = 0;
        }
        if k == count {
            if tx.send((generation, None)).is_err() {
                return;
            }
            // Wait for a seek or the end of the stream.
            while c.generation.load(Ordering::Acquire) == generation {
                if c.stop.load(Ordering::Acquire) {
                    return;
                }
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            continue;
        }
        let frame = dec.decode(k).map_err(|e| e.to_string());
        c.decoded.fetch_add(1, Ordering::AcqRel);
        if tx.send((generation, Some(frame))).is_err() {
            return;
        }
        k += 1;
    }
}
