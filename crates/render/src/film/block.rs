//! Image blocks: weighted accumulation buffers for a rectangle of the film plus the filter's border.

use super::filter::{ReconstructionFilter, MAX_FILTER_RADIUS};
use crate::color::Rgb;
use glam::{IVec2, UVec2, Vec2, Vec3};

/// Arbitrary output variables recorded with a sample, filtered with the same weights as the radiance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AovSample {
    /// Reflectance estimate at the first hit (linear RGB).
    pub albedo: Rgb,
    /// Shading normal at the first hit (world space).
    pub normal: Vec3,
    /// Distance from the camera to the first hit along the ray (0 if the ray escaped).
    pub depth: f32,
}

/// Channels stored per pixel without AOVs: Σw·R, Σw·G, Σw·B, Σw.
const BASE_CHANNELS: usize = 4;
/// Extra channels per pixel with AOVs: albedo RGB, normal XYZ, depth.
const AOV_CHANNELS: usize = 7;

/// Accumulates filtered samples for the pixels `offset .. offset + size` of the film plus `border`
/// pixels on every side (so that splats of samples drawn inside the block are kept whole). Per pixel
/// it stores Σw·L (RGB), Σw and optionally Σw·AOV, in f64 so that merging is insensitive to rounding.
/// Samples with a non-finite value, AOV or position are rejected and counted, never written.
#[derive(Clone, Debug)]
pub struct ImageBlock {
    offset: IVec2,
    size: UVec2,
    border: u32,
    filter: ReconstructionFilter,
    channels: usize,
    data: Vec<f64>,
    rejected: u64,
}

impl ImageBlock {
    /// A cleared block for film pixels `offset .. offset + size`, with the border `filter` needs.
    pub fn new(offset: IVec2, size: UVec2, filter: &ReconstructionFilter, with_aovs: bool) -> Self {
        Self::with_border(offset, size, filter, with_aovs, filter.border_size())
    }

    /// A cleared block with an explicit border (0 for the film's own storage).
    pub(crate) fn with_border(
        offset: IVec2,
        size: UVec2,
        filter: &ReconstructionFilter,
        with_aovs: bool,
        border: u32,
    ) -> Self {
        let channels = BASE_CHANNELS + if with_aovs { AOV_CHANNELS } else { 0 };
        let ext = size + UVec2::splat(2 * border);
        ImageBlock {
            offset,
            size,
            border,
            filter: filter.clone(),
            channels,
            data: vec![0.0; ext.x as usize * ext.y as usize * channels],
            rejected: 0,
        }
    }

    /// Film pixel of the interior's top-left corner.
    pub fn offset(&self) -> IVec2 {
        self.offset
    }

    /// Interior size in pixels.
    pub fn size(&self) -> UVec2 {
        self.size
    }

    /// Border width in pixels on each side.
    pub fn border(&self) -> u32 {
        self.border
    }

    /// True if the block also accumulates AOVs.
    pub fn has_aovs(&self) -> bool {
        self.channels > BASE_CHANNELS
    }

    /// Number of samples rejected because they were not finite.
    pub fn rejected_samples(&self) -> u64 {
        self.rejected
    }

    /// The reconstruction filter samples are splatted with.
    pub fn filter(&self) -> &ReconstructionFilter {
        &self.filter
    }

    /// Zeroes the block and moves it to a new interior offset, so one allocation serves many tiles.
    pub fn reset(&mut self, offset: IVec2) {
        self.offset = offset;
        self.data.fill(0.0);
        self.rejected = 0;
    }

    /// The raw accumulators (per stored pixel: Σw·RGB, Σw, then Σw·AOVs) and the rejection count, for
    /// checkpoints that must resume bit-identically.
    pub(crate) fn raw(&self) -> (&[f64], u64) {
        (&self.data, self.rejected)
    }

    /// Restores accumulators saved with [`ImageBlock::raw`]; an error if the length does not match.
    pub(crate) fn restore_raw(&mut self, data: &[f64], rejected: u64) -> Result<(), String> {
        if data.len() != self.data.len() {
            return Err(format!(
                "accumulator size {} does not match this film ({})",
                data.len(),
                self.data.len()
            ));
        }
        self.data.copy_from_slice(data);
        self.rejected = rejected;
        Ok(())
    }

    fn ext_size(&self) -> UVec2 {
        self.size + UVec2::splat(2 * self.border)
    }

    /// Film pixel of the stored region's top-left corner (border included).
    fn origin(&self) -> IVec2 {
        self.offset - IVec2::splat(self.border as i32)
    }

    /// Adds a sample of radiance `value` taken at film position `film_pos` (pixels, (0, 0) = top-left
    /// corner of the film) to every stored pixel whose centre lies within the filter radius. Returns
    /// false if the sample was rejected because it is not finite.
    pub fn put(&mut self, film_pos: Vec2, value: Rgb, aovs: Option<&AovSample>) -> bool {
        let aov_ok = aovs
            .is_none_or(|a| a.albedo.is_finite() && a.normal.is_finite() && a.depth.is_finite());
        if !(film_pos.is_finite() && value.is_finite() && aov_ok) {
            self.rejected += 1;
            return false;
        }
        let mut values = [0.0f64; BASE_CHANNELS + AOV_CHANNELS];
        values[0] = value.x as f64;
        values[1] = value.y as f64;
        values[2] = value.z as f64;
        values[3] = 1.0;
        if let Some(a) = aovs.filter(|_| self.has_aovs()) {
            let v = [
                a.albedo.x, a.albedo.y, a.albedo.z, a.normal.x, a.normal.y, a.normal.z, a.depth,
            ];
            for (dst, src) in values[BASE_CHANNELS..].iter_mut().zip(v) {
                *dst = src as f64;
            }
        }
        let values = &values[..self.channels];
        let ext = self.ext_size().as_ivec2();
        // Samples far outside the stored region touch nothing; bailing out early also keeps the integer
        // conversions below away from saturation.
        let reach = self.filter.radius() + 1.0;
        let lo_bound = self.origin().as_vec2() - Vec2::splat(reach);
        let hi_bound = (self.origin() + ext).as_vec2() + Vec2::splat(reach);
        if film_pos.cmplt(lo_bound).any() || film_pos.cmpgt(hi_bound).any() {
            return true;
        }

        if self.filter.is_box() {
            let p = film_pos.floor().as_ivec2() - self.origin();
            if p.cmpge(IVec2::ZERO).all() && p.cmplt(ext).all() {
                self.accumulate(p, values, 1.0);
            }
            return true;
        }

        // Continuous position in the stored region where pixel centres sit at integers.
        let pos = film_pos - self.origin().as_vec2() - Vec2::splat(0.5);
        let r = self.filter.radius();
        let lo = (pos - Vec2::splat(r)).ceil().as_ivec2().max(IVec2::ZERO);
        let hi = (pos + Vec2::splat(r))
            .floor()
            .as_ivec2()
            .min(ext - IVec2::ONE);
        if lo.cmpgt(hi).any() {
            return true;
        }
        // At most 2r + 1 weights per axis; scenes cannot ask for r > MAX_FILTER_RADIUS.
        const MAX_TAPS: usize = 2 * MAX_FILTER_RADIUS as usize + 2;
        let mut wx = [0.0f32; MAX_TAPS];
        let mut wy = [0.0f32; MAX_TAPS];
        let nx = ((hi.x - lo.x + 1) as usize).min(wx.len());
        let ny = ((hi.y - lo.y + 1) as usize).min(wy.len());
        self.filter.eval_row(lo.x as f32 - pos.x, &mut wx[..nx]);
        self.filter.eval_row(lo.y as f32 - pos.y, &mut wy[..ny]);
        let (first, stride) = (
            lo.y as usize * ext.x as usize + lo.x as usize,
            ext.x as usize,
        );
        if self.channels == BASE_CHANNELS {
            splat::<BASE_CHANNELS>(&mut self.data, first, stride, &wx[..nx], &wy[..ny], values);
        } else {
            splat::<{ BASE_CHANNELS + AOV_CHANNELS }>(
                &mut self.data,
                first,
                stride,
                &wx[..nx],
                &wy[..ny],
                values,
            );
        }
        true
    }

    #[inline]
    fn accumulate(&mut self, p: IVec2, values: &[f64], w: f64) {
        let idx = (p.y as usize * self.ext_size().x as usize + p.x as usize) * self.channels;
        for (dst, v) in self.data[idx..idx + self.channels].iter_mut().zip(values) {
            *dst += w * v;
        }
    }

    /// Adds the overlapping part of `other` (border included) into this block; pixels of `other` outside
    /// this block's stored region are dropped (e.g. splats beyond the film's edge). Rejection counts add
    /// up. Both blocks must have the same channels.
    pub fn add_block(&mut self, other: &ImageBlock) {
        assert_eq!(
            self.channels, other.channels,
            "ImageBlock::add_block: AOV layout mismatch"
        );
        self.rejected += other.rejected;
        let (dst_origin, dst_ext) = (self.origin(), self.ext_size().as_ivec2());
        let (src_origin, src_ext) = (other.origin(), other.ext_size().as_ivec2());
        let lo = dst_origin.max(src_origin);
        let hi = (dst_origin + dst_ext).min(src_origin + src_ext);
        if lo.cmpge(hi).any() {
            return;
        }
        let row_len = (hi.x - lo.x) as usize * self.channels;
        for y in lo.y..hi.y {
            let d = ((y - dst_origin.y) as usize * dst_ext.x as usize
                + (lo.x - dst_origin.x) as usize)
                * self.channels;
            let s = ((y - src_origin.y) as usize * src_ext.x as usize
                + (lo.x - src_origin.x) as usize)
                * other.channels;
            for (a, b) in self.data[d..d + row_len]
                .iter_mut()
                .zip(&other.data[s..s + row_len])
            {
                *a += *b;
            }
        }
    }

    /// The accumulated (Σw·R, Σw·G, Σw·B) and Σw of film pixel `pixel`, if it is stored in this block.
    pub fn weighted_sum(&self, pixel: IVec2) -> Option<([f64; 3], f64)> {
        let c = self.pixel_channels(pixel)?;
        Some(([c[0], c[1], c[2]], c[3]))
    }

    /// All accumulated channels of film pixel `pixel` (Σw·RGB, Σw, then Σw·AOVs when present).
    pub(crate) fn pixel_channels(&self, pixel: IVec2) -> Option<&[f64]> {
        let p = pixel - self.origin();
        let ext = self.ext_size().as_ivec2();
        if p.cmplt(IVec2::ZERO).any() || p.cmpge(ext).any() {
            return None;
        }
        let idx = (p.y as usize * ext.x as usize + p.x as usize) * self.channels;
        Some(&self.data[idx..idx + self.channels])
    }
}

/// Adds w_x[i]·w_y[j]·`values` to the `C` channels of the stored pixels `first + j·stride + i` (the
/// separable splat of [`ImageBlock::put`], with the channel count known at compile time so that the
/// per-tap loop unrolls; the same products and sums, in the same order, as one tap at a time).
#[inline]
fn splat<const C: usize>(
    data: &mut [f64],
    first: usize,
    stride: usize,
    wx: &[f32],
    wy: &[f32],
    values: &[f64],
) {
    let values: &[f64; C] = values.try_into().expect("channel count");
    for (j, &w_y) in wy.iter().enumerate() {
        if w_y == 0.0 {
            continue;
        }
        let row = (first + j * stride) * C;
        let pixels = data[row..row + wx.len() * C].chunks_exact_mut(C);
        for (&w_x, pixel) in wx.iter().zip(pixels) {
            let w = w_x as f64 * w_y as f64;
            if w != 0.0 {
                for (dst, v) in pixel.iter_mut().zip(values) {
                    *dst += w * v;
                }
            }
        }
    }
}
