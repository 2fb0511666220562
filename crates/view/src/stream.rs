//! Streaming playback of a baked asset (paper A §6): while frame `k` renders, a background
//! thread reads frames `k+1..k+n` from the memory-mapped `.haze` file — RBF array and the
//! hash volume holding the frame's residual — so the renderer never waits on I/O or
//! decoding.
//!
//! Memory is bounded whatever the sequence length: at most `ahead` decoded frames wait in
//! the queue, one more is being decoded and one is held by the caller; a hash volume is
//! decoded once and shared (`Arc`) by those of its frames (up to 27) that are in flight,
//! and the stream decodes the next hash volume on a thread of its own as soon as it
//! enters one (playback would otherwise wait at each volume's first frame), so at most
//! three are alive in order playback, each within the size its bake closed volumes at
//! (`haze bake --volume-mib`, 128 MiB by default). A volume met without a decode ahead
//! (the first frame, a seek, `haze render --frame`) is decoded first only up to the frame
//! asked for — its values are coded frame after frame — and whole after that (on its own
//! thread in playback), so a picture never waits for the frames after its own. Scrubbing ([`FrameStream::seek`])
//! restarts the reader at the new frame and discards what it had read ahead. A damaged
//! block is reported on its frame, with the file and the block named, and playback goes
//! on.
//!
//! A packed asset's frame (`haze pack`: a raw volume) plays as a frame with no RBFs and
//! the whole density as a lossless residual, hashed as it is read (tens of ms a frame).

use haze_asset::{Asset, AssetError, BlockKind, Scope, decode_raw_volume, decode_rbfs};
use haze_hash::tile::{DEFAULT_BRICK, ResidualGroup};
use haze_hash::{BuildOptions, QuantOptions, quantize};
use haze_volume::{Bbox, Rbf};
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

/// A hash volume being decoded on a thread of its own: its block index and the thread.
type Pending = (usize, JoinHandle<Result<ResidualGroup, AssetError>>);

/// Reads frames out of an asset, reusing the hash volume while consecutive frames share it.
#[derive(Debug)]
pub struct FrameDecoder {
    asset: Arc<Asset>,
    /// The last hash volume decoded: its block index and contents.
    cached: Option<(usize, Arc<ResidualGroup>)>,
    /// Whether to decode the hash volume after the cached one ahead (playback).
    prefetch: bool,
    /// Whether the volume after the last is the first again (looping playback).
    wrap: bool,
    next: Option<Pending>,
}

impl FrameDecoder {
    /// A decoder that decodes what it is asked for (single frames, scrubbing).
    pub fn new(asset: Arc<Asset>) -> FrameDecoder {
        FrameDecoder {
            asset,
            cached: None,
            prefetch: false,
            wrap: false,
            next: None,
        }
    }

    /// A decoder for playback in order: entering a hash volume starts decoding the next
    /// one on a thread of its own (after the last, the first again when `looping`).
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

    /// The block index of the hash volume being decoded ahead, if any.
    pub fn decoding_ahead(&self) -> Option<usize> {
        self.next.as_ref().map(|(j, _)| *j)
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
        let covering = |kind: BlockKind| {
            a.entries()
                .iter()
                .position(|e| e.kind == kind && e.scope.covers(k as u32) && e.scope != Scope::Asset)
        };
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
                    unreachable!("covering() excludes asset-wide blocks")
                };
                let slot = k - first as usize;
                let group = self.group(i, slot)?;
                Some(ResidualSlot { group, slot })
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
    /// Hash volume `i` (a block index) holding at least its frames up to `slot`: cached,
    /// taken from the thread that decoded it ahead, or decoded now. A volume met without a
    /// decode ahead is decoded now only up to `slot` (a single frame's render, the first
    /// picture and a seek need not wait for the volume's later frames); a prefetching
    /// decoder then decodes the whole volume on a thread of its own, and one that does not
    /// prefetch decodes it when a later frame of it is asked for: at most two decodes a
    /// volume. Once a volume is whole, a prefetching decoder starts on the one after.
    fn group(&mut self, i: usize, slot: usize) -> Result<Arc<ResidualGroup>, AssetError> {
        let partial = match &self.cached {
            Some((c, g)) if *c == i && g.frames() > slot => return Ok(g.clone()),
            Some((c, _)) => *c == i,
            None => false,
        };
        let (g, whole) = match self.next.take() {
            Some((n, thread)) if n == i => {
                let g = thread.join().unwrap_or_else(|_| {
                    Err(AssetError::Invalid {
                        path: self.asset.path().to_path_buf(),
                        what: format!("the thread decoding block {i} failed"),
                    })
                })?;
                (g, true)
            }
            _ if partial => (decode_group(&self.asset, i, usize::MAX)?, true),
            _ => {
                let g = decode_group(&self.asset, i, slot)?;
                let more = matches!(self.asset.entries()[i].scope,
                    Scope::Frames { count, .. } if g.frames() < count as usize);
                (g, !more)
            }
        };
        let g = Arc::new(g);
        self.cached = Some((i, g.clone()));
        if self.prefetch {
            let ahead = if whole { self.volume_after(i) } else { Some(i) };
            self.next = ahead.map(|j| {
                let asset = self.asset.clone();
                (
                    j,
                    std::thread::spawn(move || decode_group(&asset, j, usize::MAX)),
                )
            });
        }
        Ok(g)
    }

    /// The hash volume holding the frame after volume `i`'s last (frame 0 after the
    /// asset's last when looping), if it is another one.
    fn volume_after(&self, i: usize) -> Option<usize> {
        let a = &*self.asset;
        let Scope::Frames { first, count } = a.entries()[i].scope else {
            return None;
        };
        let after = first as usize + count as usize;
        if after >= a.frame_count() && !self.wrap {
            return None;
        }
        let next = after % a.frame_count().max(1);
        a.entries()
            .iter()
            .position(|e| {
                e.kind == BlockKind::ResidualHash
                    && e.scope.covers(next as u32)
                    && e.scope != Scope::Asset
            })
            .filter(|&j| j != i)
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
