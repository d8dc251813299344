//! The film: its parameters from the scene (`hdrfilm`), and the accumulation of image blocks into the
//! final image.

use super::block::ImageBlock;
use super::filter::{filter_from_desc, ReconstructionFilter};
use super::image::{Image, ImageLayer};
use crate::desc::{ObjectClass, ObjectDesc};
use crate::error::SceneResult;
use glam::{IVec2, UVec2};

/// The pixel format a film asks for. focal always writes RGB (plus AOV layers); `Rgba` is accepted for
/// compatibility and written without alpha.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelFormat {
    /// `rgb`.
    Rgb,
    /// `rgba`.
    Rgba,
}

/// Film parameters: full size, crop window and reconstruction filter.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmSpec {
    /// Full film width in pixels (the camera's aspect ratio uses the full size).
    pub width: u32,
    /// Full film height in pixels.
    pub height: u32,
    /// Top-left pixel of the rendered window.
    pub crop_offset: UVec2,
    /// Size of the rendered window (= the developed image's size).
    pub crop_size: UVec2,
    /// Reconstruction filter.
    pub filter: ReconstructionFilter,
    /// Requested pixel format.
    pub pixel_format: PixelFormat,
}

impl Default for FilmSpec {
    /// Mitsuba's default film: 768×576, no crop, Gaussian filter.
    fn default() -> Self {
        FilmSpec {
            width: 768,
            height: 576,
            crop_offset: UVec2::ZERO,
            crop_size: UVec2::new(768, 576),
            filter: ReconstructionFilter::default(),
            pixel_format: PixelFormat::Rgb,
        }
    }
}

/// Longest film side accepted: 2^16 keeps pixel indices and f32 film coordinates exact.
pub const MAX_FILM_SIDE: u32 = 1 << 16;

impl FilmSpec {
    /// The full film size.
    pub fn size(&self) -> UVec2 {
        UVec2::new(self.width, self.height)
    }

    /// The film at another size: `width` × `height`, or `width` with the film's aspect ratio when
    /// `height` is `None`. A crop window scales with the film (a whole-film window stays whole).
    pub fn resized(&self, width: u32, height: Option<u32>) -> Result<FilmSpec, String> {
        let height = height.unwrap_or_else(|| {
            ((width as f64 * self.height as f64 / self.width as f64).round() as u32).max(1)
        });
        for (name, v) in [("width", width), ("height", height)] {
            if v == 0 || v > MAX_FILM_SIDE {
                return Err(format!(
                    "film {name} {v} is outside 1..={MAX_FILM_SIDE} (from the requested size \
                     {width}x{height})"
                ));
            }
        }
        let new = UVec2::new(width, height);
        let (crop_offset, crop_size) =
            if self.crop_offset == UVec2::ZERO && self.crop_size == self.size() {
                (UVec2::ZERO, new)
            } else {
                let scale = new.as_dvec2() / self.size().as_dvec2();
                let offset = (self.crop_offset.as_dvec2() * scale)
                    .floor()
                    .as_uvec2()
                    .min(new - UVec2::ONE);
                let size = (self.crop_size.as_dvec2() * scale)
                    .round()
                    .as_uvec2()
                    .max(UVec2::ONE)
                    .min(new - offset);
                (offset, size)
            };
        Ok(FilmSpec {
            width,
            height,
            crop_offset,
            crop_size,
            ..self.clone()
        })
    }
}

/// Reads a `<film>` (None gives Mitsuba's default film). `hdrfilm` is fully supported; `ldrfilm` and
/// Mitsuba 0.6's `tiledhdrfilm` are accepted with the same parameters and rendered the same way (focal
/// always writes linear EXR plus an optional tonemapped PNG, so tonemapping parameters are ignored).
/// Other film plugins are errors.
/// Reads `width`/`height` (768×576), the `rfilter` child (Gaussian σ = 0.5), `pixel_format` (rgb or
/// rgba), and `crop_offset_x/y`, `crop_width/height` (default: the whole film).
pub fn film_from_desc(film: Option<&ObjectDesc>) -> SceneResult<FilmSpec> {
    let Some(d) = film else {
        return Ok(FilmSpec::default());
    };
    if !matches!(d.plugin.as_str(), "hdrfilm" | "ldrfilm" | "tiledhdrfilm") {
        return Err(d.error(format!(
            "unsupported film type '{}' (supported: hdrfilm, ldrfilm, tiledhdrfilm)",
            d.plugin
        )));
    }
    let dim = |name: &str, default: i64, min: i64, max: i64| -> SceneResult<u32> {
        let v = d.int_or(name, default)?;
        if v < min || v > max {
            return Err(d.error(format!("film '{name}' must be in {min}..={max}, got {v}")));
        }
        Ok(v as u32)
    };
    const MAX_SIDE: i64 = MAX_FILM_SIDE as i64;
    let width = dim("width", 768, 1, MAX_SIDE)?;
    let height = dim("height", 576, 1, MAX_SIDE)?;
    let crop_offset = UVec2::new(
        dim("crop_offset_x", 0, 0, width as i64 - 1)?,
        dim("crop_offset_y", 0, 0, height as i64 - 1)?,
    );
    let crop_size = UVec2::new(
        dim("crop_width", (width - crop_offset.x) as i64, 1, MAX_SIDE)?,
        dim("crop_height", (height - crop_offset.y) as i64, 1, MAX_SIDE)?,
    );
    if (crop_offset + crop_size)
        .cmpgt(UVec2::new(width, height))
        .any()
    {
        return Err(d.error(format!(
            "the crop window (offset {}x{}, size {}x{}) does not fit in the {width}x{height} film",
            crop_offset.x, crop_offset.y, crop_size.x, crop_size.y
        )));
    }
    let pixel_format = match d
        .string_or("pixel_format", "rgb")?
        .to_ascii_lowercase()
        .as_str()
    {
        "rgb" => PixelFormat::Rgb,
        "rgba" => PixelFormat::Rgba,
        other => {
            return Err(d.error(format!(
                "pixel_format '{other}' is not supported (focal writes 'rgb'; 'rgba' is accepted)"
            )))
        }
    };
    let mut rfilters = d.children_of(&ObjectClass::Rfilter);
    let rfilter = rfilters.next();
    if let Some(extra) = rfilters.next() {
        return Err(extra.object.error("a film can have only one <rfilter>"));
    }
    let filter = filter_from_desc(rfilter.map(|c| c.object.as_ref()))?;
    Ok(FilmSpec {
        width,
        height,
        crop_offset,
        crop_size,
        filter,
        pixel_format,
    })
}

/// Names of the AOV layers a film with AOVs develops, with their channel names, in storage order.
pub const AOV_LAYERS: [(&str, &[&str]); 3] = [
    ("albedo", &["R", "G", "B"]),
    ("normal", &["X", "Y", "Z"]),
    ("depth", &["Z"]),
];

/// Name of the EXR layer holding a film's per-pixel filter weight Σw (channel `W`): with it, images of
/// disjoint sample sets of one render (its shards) merge into exactly the image of all their samples,
/// Σ Iᵢ·Wᵢ / Σ Wᵢ, whatever the reconstruction filter.
pub const FILTER_WEIGHT_LAYER: &str = "filter_weight";

/// The film being rendered: accumulated Σw·L and Σw for every pixel of the crop window. Render workers
/// fill their own [`ImageBlock`]s (see [`Film::create_block`]) and the caller merges them in a fixed
/// order, so the result is deterministic.
#[derive(Clone, Debug)]
pub struct Film {
    spec: FilmSpec,
    storage: ImageBlock,
}

impl Film {
    /// An empty film; `with_aovs` adds albedo, normal and depth layers.
    pub fn new(spec: FilmSpec, with_aovs: bool) -> Self {
        let storage = ImageBlock::with_border(
            spec.crop_offset.as_ivec2(),
            spec.crop_size,
            &spec.filter,
            with_aovs,
            0,
        );
        Film { spec, storage }
    }

    /// The film parameters.
    pub fn spec(&self) -> &FilmSpec {
        &self.spec
    }

    /// Width of the developed image (the crop width).
    pub fn width(&self) -> u32 {
        self.spec.crop_size.x
    }

    /// Height of the developed image (the crop height).
    pub fn height(&self) -> u32 {
        self.spec.crop_size.y
    }

    /// The reconstruction filter.
    pub fn filter(&self) -> &ReconstructionFilter {
        &self.spec.filter
    }

    /// True if the film accumulates AOV layers.
    pub fn has_aovs(&self) -> bool {
        self.storage.has_aovs()
    }

    /// Total samples rejected as non-finite by the blocks merged so far.
    pub fn rejected_samples(&self) -> u64 {
        self.storage.rejected_samples()
    }

    /// A cleared block for film pixels `offset .. offset + size` (film coordinates, crop offset included)
    /// with this film's filter, border and AOV layout.
    pub fn create_block(&self, offset: IVec2, size: UVec2) -> ImageBlock {
        ImageBlock::new(offset, size, &self.spec.filter, self.has_aovs())
    }

    /// Adds a block; splats that fall outside the crop window are dropped (as Mitsuba does).
    pub fn merge_block(&mut self, block: &ImageBlock) {
        self.storage.add_block(block);
    }

    /// Adds all samples of another film of the same spec (e.g. one pass's film into a running total).
    pub fn merge_film(&mut self, other: &Film) {
        self.storage.add_block(&other.storage);
    }

    /// The raw accumulators (per pixel Σw·RGB, Σw, then Σw·AOVs) and the rejection count, for a
    /// checkpoint from which a render resumes bit-identically.
    pub fn accumulators(&self) -> (&[f64], u64) {
        self.storage.raw()
    }

    /// Restores accumulators saved with [`Film::accumulators`]; an error if their size does not match.
    pub fn restore_accumulators(&mut self, data: &[f64], rejected: u64) -> Result<(), String> {
        self.storage.restore_raw(data, rejected)
    }

    /// Clears all accumulated samples.
    pub fn clear(&mut self) {
        let offset = self.storage.offset();
        self.storage.reset(offset);
    }

    /// The per-pixel filter weight Σw of the crop window as a [`FILTER_WEIGHT_LAYER`] layer.
    pub fn weight_layer(&self) -> ImageLayer {
        let (w, h) = (self.width(), self.height());
        let mut layer = ImageLayer::new(FILTER_WEIGHT_LAYER, &["W"], w, h);
        let origin = self.storage.offset();
        for y in 0..h {
            for x in 0..w {
                let c = self
                    .storage
                    .pixel_channels(origin + IVec2::new(x as i32, y as i32))
                    .expect("film storage covers the crop window");
                layer.data[(y * w + x) as usize] = c[3] as f32;
            }
        }
        layer
    }

    /// The image: Σw·L / Σw per pixel, 0 where Σw = 0; AOVs likewise (normals are averaged, not
    /// renormalised). Row 0 is the top of the image.
    pub fn develop(&self) -> Image {
        let (w, h) = (self.width(), self.height());
        let mut image = Image::new(w, h);
        let mut layers: Vec<ImageLayer> = if self.has_aovs() {
            AOV_LAYERS
                .iter()
                .map(|(name, ch)| ImageLayer::new(name, ch, w, h))
                .collect()
        } else {
            Vec::new()
        };
        let origin = self.storage.offset();
        for y in 0..h {
            for x in 0..w {
                let c = self
                    .storage
                    .pixel_channels(origin + IVec2::new(x as i32, y as i32))
                    .expect("film storage covers the crop window");
                let weight = c[3];
                let inv = if weight != 0.0 { 1.0 / weight } else { 0.0 };
                let i = (y * w + x) as usize;
                image.rgb[i] = [
                    (c[0] * inv) as f32,
                    (c[1] * inv) as f32,
                    (c[2] * inv) as f32,
                ];
                let mut k = 4;
                for layer in &mut layers {
                    let n = layer.channels.len();
                    for j in 0..n {
                        layer.data[i * n + j] = (c[k + j] * inv) as f32;
                    }
                    k += n;
                }
            }
        }
        image.layers = layers;
        image.sanitize();
        image
    }
}
