//! Developed images: linear RGB plus named layers (AOVs), with EXR and PNG input/output and the
//! pixel statistics the render loop and the reference comparisons need.

use crate::color::linear_to_srgb;
use serde::Serialize;
use std::io;
use std::path::Path;

/// An extra image layer, e.g. `albedo` with channels R, G, B. In EXR files its channels are named
/// `<layer>.<channel>` ("albedo.R", "normal.X", "depth.Z"); a layer with an empty name writes bare
/// channel names.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageLayer {
    /// Layer name (the EXR channel prefix).
    pub name: String,
    /// Channel names within the layer, in storage order.
    pub channels: Vec<String>,
    /// Interleaved samples, row-major from the top row: `data[(y * width + x) * channels.len() + c]`.
    pub data: Vec<f32>,
}

impl ImageLayer {
    /// A zero layer of `width × height` pixels.
    pub fn new(name: &str, channels: &[&str], width: u32, height: u32) -> Self {
        ImageLayer {
            name: name.to_string(),
            channels: channels.iter().map(|c| c.to_string()).collect(),
            data: vec![0.0; width as usize * height as usize * channels.len()],
        }
    }

    /// The EXR channel name of channel `c`.
    pub fn exr_channel_name(&self, c: usize) -> String {
        if self.name.is_empty() {
            self.channels[c].clone()
        } else {
            format!("{}.{}", self.name, self.channels[c])
        }
    }
}

/// Summary statistics of an image's RGB, ready to be written to a JSON run record.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ImageStats {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Mean linear RGB.
    pub mean_rgb: [f64; 3],
    /// Mean luminance (Rec. 709 weights).
    pub mean_luminance: f64,
    /// Per-channel minimum over finite values (0 for an image without finite values).
    pub min_rgb: [f32; 3],
    /// Per-channel maximum over finite values.
    pub max_rgb: [f32; 3],
    /// Number of non-finite RGB values (0 after [`Image::sanitize`]).
    pub non_finite: usize,
}

/// A linear RGB image (row 0 = top) with optional extra layers of the same size.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB, row-major from the top row.
    pub rgb: Vec<[f32; 3]>,
    /// Extra layers (AOVs), each `width × height`.
    pub layers: Vec<ImageLayer>,
}

fn invalid(path: &Path, msg: impl std::fmt::Display) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("{}: {msg}", path.display()),
    )
}

/// Canonical order of channels within a layer when reading (EXR stores them alphabetically).
fn channel_rank(name: &str) -> (usize, String) {
    let order = ["R", "G", "B", "A", "X", "Y", "Z", "U", "V", "W"];
    (
        order.iter().position(|o| *o == name).unwrap_or(order.len()),
        name.to_string(),
    )
}

impl Image {
    /// A black image without layers.
    pub fn new(width: u32, height: u32) -> Self {
        Image {
            width,
            height,
            rgb: vec![[0.0; 3]; width as usize * height as usize],
            layers: Vec::new(),
        }
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The RGB value of pixel (x, y), row 0 being the top.
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 3] {
        self.rgb[(y * self.width + x) as usize]
    }

    /// The layer with this name.
    pub fn layer(&self, name: &str) -> Option<&ImageLayer> {
        self.layers.iter().find(|l| l.name == name)
    }

    /// Mean RGB over all pixels, accumulated in f64.
    pub fn mean_rgb(&self) -> [f64; 3] {
        let mut sum = [0.0f64; 3];
        for p in &self.rgb {
            for c in 0..3 {
                sum[c] += p[c] as f64;
            }
        }
        let n = self.pixel_count().max(1) as f64;
        sum.map(|s| s / n)
    }

    /// Mean, luminance, range and non-finite count of the RGB channels.
    pub fn stats(&self) -> ImageStats {
        let mean_rgb = self.mean_rgb();
        let mut min_rgb = [f32::INFINITY; 3];
        let mut max_rgb = [f32::NEG_INFINITY; 3];
        let mut non_finite = 0;
        for p in &self.rgb {
            for c in 0..3 {
                if p[c].is_finite() {
                    min_rgb[c] = min_rgb[c].min(p[c]);
                    max_rgb[c] = max_rgb[c].max(p[c]);
                } else {
                    non_finite += 1;
                }
            }
        }
        let finite_or_zero = |v: [f32; 3]| v.map(|x| if x.is_finite() { x } else { 0.0 });
        ImageStats {
            width: self.width,
            height: self.height,
            mean_rgb,
            mean_luminance: 0.212671 * mean_rgb[0]
                + 0.715160 * mean_rgb[1]
                + 0.072169 * mean_rgb[2],
            min_rgb: finite_or_zero(min_rgb),
            max_rgb: finite_or_zero(max_rgb),
            non_finite,
        }
    }

    /// Replaces every non-finite value (RGB and layers) by 0, so no NaN/Inf ever leaves the renderer.
    /// Returns how many values were replaced.
    pub fn sanitize(&mut self) -> usize {
        let mut fixed = 0;
        let mut fix = |v: &mut f32| {
            if !v.is_finite() {
                *v = 0.0;
                fixed += 1;
            }
        };
        self.rgb.iter_mut().flatten().for_each(&mut fix);
        self.layers
            .iter_mut()
            .flat_map(|l| l.data.iter_mut())
            .for_each(&mut fix);
        fixed
    }

    fn assert_same_shape(&self, other: &Image) {
        assert!(
            self.width == other.width
                && self.height == other.height
                && self.layers.len() == other.layers.len()
                && self
                    .layers
                    .iter()
                    .zip(&other.layers)
                    .all(|(a, b)| a.channels == b.channels),
            "image arithmetic needs images of the same size and layers"
        );
    }

    /// `self += scale · other`, pixel by pixel, layers included (same size and layers required).
    pub fn add_scaled(&mut self, other: &Image, scale: f64) {
        self.assert_same_shape(other);
        for (a, b) in self.rgb.iter_mut().zip(&other.rgb) {
            for c in 0..3 {
                a[c] = (a[c] as f64 + scale * b[c] as f64) as f32;
            }
        }
        for (la, lb) in self.layers.iter_mut().zip(&other.layers) {
            for (a, b) in la.data.iter_mut().zip(&lb.data) {
                *a = (*a as f64 + scale * *b as f64) as f32;
            }
        }
    }

    /// Multiplies every value (layers included) by `scale`.
    pub fn scale(&mut self, scale: f64) {
        self.rgb
            .iter_mut()
            .flatten()
            .for_each(|v| *v = (*v as f64 * scale) as f32);
        self.layers
            .iter_mut()
            .flat_map(|l| l.data.iter_mut())
            .for_each(|v| *v = (*v as f64 * scale) as f32);
    }

    /// The per-pixel mean of several images of the same size and layers (e.g. independent render
    /// passes), accumulated in f64. `None` for an empty slice.
    pub fn mean(images: &[Image]) -> Option<Image> {
        let first = images.first()?;
        let n = images.len() as f64;
        let mut rgb = vec![[0.0f64; 3]; first.pixel_count()];
        let mut layers: Vec<Vec<f64>> = first
            .layers
            .iter()
            .map(|l| vec![0.0; l.data.len()])
            .collect();
        for img in images {
            first.assert_same_shape(img);
            for (a, b) in rgb.iter_mut().zip(&img.rgb) {
                for c in 0..3 {
                    a[c] += b[c] as f64;
                }
            }
            for (la, lb) in layers.iter_mut().zip(&img.layers) {
                for (a, b) in la.iter_mut().zip(&lb.data) {
                    *a += *b as f64;
                }
            }
        }
        let mut out = first.clone();
        for (o, a) in out.rgb.iter_mut().zip(&rgb) {
            *o = a.map(|v| (v / n) as f32);
        }
        for (lo, la) in out.layers.iter_mut().zip(&layers) {
            for (o, a) in lo.data.iter_mut().zip(la) {
                *o = (a / n) as f32;
            }
        }
        Some(out)
    }

    /// Writes a linear float32 OpenEXR file (ZIP compression) with channels R, G, B and every layer's
    /// channels as `<layer>.<channel>` (see [`ImageLayer`]).
    pub fn write_exr(&self, path: &Path) -> io::Result<()> {
        use exr::prelude::traits::*;
        use exr::prelude::{
            AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, SmallVec,
        };
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 {
            return Err(invalid(path, "cannot write an empty image"));
        }
        let mut list: Vec<AnyChannel<FlatSamples>> = (0..3)
            .map(|c| {
                let name = ["R", "G", "B"][c];
                AnyChannel::new(
                    name,
                    FlatSamples::F32(self.rgb.iter().map(|p| p[c]).collect()),
                )
            })
            .collect();
        for layer in &self.layers {
            let n = layer.channels.len();
            for c in 0..n {
                let samples: Vec<f32> = layer.data.iter().skip(c).step_by(n).copied().collect();
                list.push(AnyChannel::new(
                    layer.exr_channel_name(c).as_str(),
                    FlatSamples::F32(samples),
                ));
            }
        }
        let mut names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
        names.sort();
        if let Some(dup) = names.windows(2).find(|p| p[0] == p[1]) {
            return Err(invalid(
                path,
                format!("duplicate channel name '{}'", dup[0]),
            ));
        }
        let layer = Layer::new(
            (w, h),
            LayerAttributes::default(),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(list)),
        );
        exr::prelude::Image::from_layer(layer)
            .write()
            .to_file(path)
            .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))
    }

    /// Reads an OpenEXR file (half or float channels, single- or multi-part). The main image comes from
    /// the unprefixed R, G, B channels (or a single Y channel, replicated to grey); every other channel
    /// `<layer>.<channel>` becomes a layer (the part name counts as a prefix in multi-part files).
    pub fn read_exr(path: &Path) -> io::Result<Image> {
        use exr::prelude::traits::*;
        use exr::prelude::Vec2;
        let file = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_file(path)
            .map_err(|e| invalid(path, e))?;
        let mut size: Option<(usize, usize)> = None;
        let mut channels: Vec<(String, Vec<f32>)> = Vec::new();
        for layer in &file.layer_data {
            let s = (layer.size.0, layer.size.1);
            if *size.get_or_insert(s) != s {
                return Err(invalid(path, "parts of different sizes are not supported"));
            }
            let prefix = layer.attributes.layer_name.as_ref().map(|t| t.to_string());
            for ch in &layer.channel_data.list {
                let mut name = ch.name.to_string();
                if let Some(p) = prefix.as_deref().filter(|p| !p.is_empty()) {
                    name = format!("{p}.{name}");
                }
                if ch.sampling != Vec2(1, 1) {
                    return Err(invalid(
                        path,
                        format!("subsampled channel '{name}' is not supported"),
                    ));
                }
                channels.push((name, ch.sample_data.values_as_f32().collect()));
            }
        }
        let (w, h) = size.ok_or_else(|| invalid(path, "the file has no image data"))?;
        let find = |n: &str| channels.iter().position(|(name, _)| name == n);
        let mut image = Image::new(w as u32, h as u32);
        let main: Vec<usize> = match (find("R"), find("G"), find("B"), find("Y")) {
            (Some(r), Some(g), Some(b), _) => {
                for (i, p) in image.rgb.iter_mut().enumerate() {
                    *p = [channels[r].1[i], channels[g].1[i], channels[b].1[i]];
                }
                vec![r, g, b]
            }
            (_, _, _, Some(y)) => {
                for (i, p) in image.rgb.iter_mut().enumerate() {
                    *p = [channels[y].1[i]; 3];
                }
                vec![y]
            }
            _ => return Err(invalid(path, "no R, G, B (or Y) channels")),
        };
        // Group the remaining channels by prefix (everything before the last '.').
        let mut groups: Vec<(String, Vec<(String, usize)>)> = Vec::new();
        for (i, (name, _)) in channels.iter().enumerate() {
            if main.contains(&i) {
                continue;
            }
            let (layer, ch) = match name.rfind('.') {
                Some(k) => (name[..k].to_string(), name[k + 1..].to_string()),
                None => (String::new(), name.clone()),
            };
            match groups.iter_mut().find(|(l, _)| *l == layer) {
                Some((_, v)) => v.push((ch, i)),
                None => groups.push((layer, vec![(ch, i)])),
            }
        }
        for (name, mut chans) in groups {
            chans.sort_by_key(|(c, _)| channel_rank(c));
            let n = chans.len();
            let mut data = vec![0.0f32; w * h * n];
            for (c, (_, idx)) in chans.iter().enumerate() {
                for (i, v) in channels[*idx].1.iter().enumerate() {
                    data[i * n + c] = *v;
                }
            }
            image.layers.push(ImageLayer {
                name,
                channels: chans.into_iter().map(|(c, _)| c).collect(),
                data,
            });
        }
        Ok(image)
    }

    /// The 8-bit sRGB encoding of the RGB image scaled by 2^`exposure` and clamped to [0, 1]
    /// (non-finite values map to 0), row-major RGB bytes.
    pub fn to_srgb8(&self, exposure: f32) -> Vec<u8> {
        let scale = exposure.exp2();
        self.rgb
            .iter()
            .flatten()
            .map(|&v| {
                let v = if v.is_finite() {
                    (v * scale).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (linear_to_srgb(v) * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
            })
            .collect()
    }

    /// Writes a tonemapped 8-bit PNG: RGB × 2^`exposure`, clamped, sRGB-encoded.
    pub fn write_png(&self, path: &Path, exposure: f32) -> io::Result<()> {
        image::save_buffer_with_format(
            path,
            &self.to_srgb8(exposure),
            self.width,
            self.height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))
    }
}
