//! Which files a run writes (`camsim simulate --save ...`, [`crate::Simulation::write`]).

use crate::{PipelineError, Result};
use camsim_core::names::{NameTable, Named};
use std::collections::BTreeSet;

/// One kind of output file of a run. run.json is always written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Output {
    /// raw.dng (and raw_0001.dng ... for more frames): the exact ADC values.
    Raw,
    /// raw.png: the first frame's mosaic scaled to the 16-bit range, for viewing.
    RawPng,
    /// preview.png: bilinear demosaic, colour-corrected to sRGB.
    Preview,
    /// radiance.exr: the scene's spectral radiance, W/(sr m^2 nm) (with depth channel Z for 3D scenes).
    Radiance,
    /// irradiance.exr: the sensor-plane spectral irradiance, W/(m^2 nm).
    Irradiance,
    /// depth.exr: the scene's depth map, m (3D scenes; 2D charts have none, and it is skipped).
    Depth,
    /// noise_free.exr: the expected ADC value per pixel without any noise or quantization (DN).
    NoiseFree,
    /// object_id.png, material_id.png (16-bit) and ids.json (their legend): which shape and
    /// material the ray through each scene pixel's centre meets first (3D scenes; 2D charts have
    /// none, and it is skipped).
    Ids,
    /// instances.png (16-bit instance ids on the raw image's grid) and instances.scene.png (on
    /// the render's grid): 3D scenes ([`crate::labels`]).
    Instances,
    /// normals.exr / normals.scene.exr: surface normals, camera frame (`camera.X/Y/Z`) and world
    /// (`world.X/Y/Z`).
    Normals,
    /// albedo.exr / albedo.scene.exr: the first surface's reflectance, linear sRGB (`R`, `G`,
    /// `B`) and spectral (`T.<wavelength>nm`).
    Albedo,
    /// boxes.json: per instance its 3D box, 2D boxes in both geometries, visible fraction,
    /// truncation; the cameras' K and extrinsics.
    ///
    /// A moving 3D scene has one label set per raw frame, each describing the scene at the start
    /// of that frame's window: frame 1's keep these names, later frames are numbered as raw.dng's
    /// (depth_0001.exr, object_id_0001.png, instances_0001.png, instances_0001.scene.png,
    /// depth_0001.sensor.exr, boxes_0001.json, ...; ids.json, the legend, once).
    Boxes,
    /// flow.exr (flow_0001.exr ...): each frame's optical flow in sensor pixels, channels X and
    /// Y, aligned with raw.dng, and flow_next.exr ... to the next frame of a sequence (3D scenes;
    /// 2D charts have none, and it is skipped).
    Flow,
    /// preview.gif: an animation of every frame's preview (a burst, bracket or video; a run of
    /// one frame skips it), each frame shown for the frame interval.
    PreviewGif,
    /// preview.jpg: the preview as a baseline JPEG at `[isp] jpeg_quality` (default 90), the
    /// format training pipelines read.
    PreviewJpeg,
    /// In boxes.json (so only with `boxes`): each instance's full (amodal) silhouette on the raw
    /// grid, occluders ignored, as `mask_all_sensor` (COCO's uncompressed RLE) with its pixel
    /// count and box (3D scenes; BOP's `mask/`).
    Amodal,
}

/// The outputs by the name `--save` (and a dataset's `outputs`) takes.
pub const OUTPUTS: NameTable<Output> = NameTable {
    family: "output",
    entries: &[
        out(
            "raw",
            "raw.dng: the exact ADC values (raw_0001.dng ... for more frames)",
            Output::Raw,
        ),
        out(
            "raw-png",
            "raw.png: the mosaic scaled to 16 bits for viewing",
            Output::RawPng,
        ),
        out(
            "preview",
            "preview.png: the ISP's sRGB image",
            Output::Preview,
        ),
        out(
            "radiance",
            "radiance.exr: scene spectral radiance, W/(sr m^2 nm)",
            Output::Radiance,
        ),
        out(
            "irradiance",
            "irradiance.exr: sensor-plane spectral irradiance, W/(m^2 nm)",
            Output::Irradiance,
        ),
        out(
            "depth",
            "depth.exr: a 3D scene's depth map, m (depth_0001.exr ... per frame of a moving scene)",
            Output::Depth,
        ),
        out(
            "noise-free",
            "noise_free.exr: each pixel's ADC value without noise, DN",
            Output::NoiseFree,
        ),
        out(
            "ids",
            "object_id.png, material_id.png, ids.json: a 3D scene's segmentation (object_id_0001.png ... per frame of a moving scene)",
            Output::Ids,
        ),
        out(
            "instances",
            "instances.png, instances.scene.png: a 3D scene's 16-bit instance ids on the raw and render grids (instances_0001.png ... per frame of a moving scene)",
            Output::Instances,
        ),
        out(
            "normals",
            "normals.exr, normals.scene.exr: surface normals, camera frame and world (normals_0001.exr ... per frame of a moving scene)",
            Output::Normals,
        ),
        out(
            "albedo",
            "albedo.exr, albedo.scene.exr: the first surface's reflectance, linear sRGB and spectral (albedo_0001.exr ... per frame of a moving scene)",
            Output::Albedo,
        ),
        out(
            "boxes",
            "boxes.json: per instance 3D and 2D boxes, visible fraction, truncation; cameras' K and extrinsics (boxes_0001.json ... per frame of a moving scene)",
            Output::Boxes,
        ),
        out(
            "flow",
            "flow.exr (flow_0001.exr ...; flow_next*.exr to the next frame): optical flow, sensor pixels, X right, Y down (3D scenes)",
            Output::Flow,
        ),
        out(
            "preview-gif",
            "preview.gif: every frame's preview as an animation, shown at the frame rate (more than one frame)",
            Output::PreviewGif,
        ),
        out(
            "preview-jpeg",
            "preview.jpg: the ISP's sRGB image as a JPEG at [isp] jpeg_quality (default 90)",
            Output::PreviewJpeg,
        ),
        out(
            "amodal",
            "in boxes.json (with boxes): each instance's full silhouette on the raw grid, occluders ignored (COCO uncompressed RLE; BOP's mask/)",
            Output::Amodal,
        ),
    ],
};

/// Output names that are reserved for outputs still to come (refused with this reason).
const RESERVED: [(&str, &str); 1] = [(
    "flow",
    "optical flow needs the renderer's motion (moving shapes and camera), which is not there yet",
)];

const fn out(name: &'static str, about: &'static str, value: Output) -> Named<Output> {
    Named {
        name,
        aliases: &[],
        about,
        value,
    }
}

impl Output {
    /// Every output, in the order of [`OUTPUTS`].
    pub const ALL: [Output; 16] = {
        let e = OUTPUTS.entries;
        [
            e[0].value,
            e[1].value,
            e[2].value,
            e[3].value,
            e[4].value,
            e[5].value,
            e[6].value,
            e[7].value,
            e[8].value,
            e[9].value,
            e[10].value,
            e[11].value,
            e[12].value,
            e[13].value,
            e[14].value,
            e[15].value,
        ]
    };

    /// The training-data labels ([`crate::labels`]; 3D scenes only).
    pub const LABELS: [Output; 5] = [
        Output::Instances,
        Output::Normals,
        Output::Albedo,
        Output::Boxes,
        Output::Amodal,
    ];

    /// The name used in `--save` ([`OUTPUTS`]).
    pub fn name(self) -> &'static str {
        OUTPUTS.name_of(self).unwrap_or("raw")
    }
}

/// A set of outputs. Default: raw, preview (and run.json).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputSet(BTreeSet<Output>);

impl Default for OutputSet {
    fn default() -> Self {
        OutputSet([Output::Raw, Output::Preview].into_iter().collect())
    }
}

impl OutputSet {
    /// No output file (run.json only).
    pub fn none() -> Self {
        OutputSet(BTreeSet::new())
    }

    /// Every output.
    pub fn all() -> Self {
        OutputSet(Output::ALL.into_iter().collect())
    }

    /// Parse `--save`: comma-separated names (`raw,preview,radiance,irradiance,depth,noise-free,
    /// raw-png,ids`), `all`, or `default`.
    pub fn parse(text: &str) -> Result<OutputSet> {
        let mut set = BTreeSet::new();
        for item in text.split(',').map(str::trim) {
            match item {
                "all" => set.extend(Output::ALL),
                "default" => set.extend(OutputSet::default().0),
                _ => match OUTPUTS.entry(item) {
                    Some(o) => {
                        set.insert(o.value);
                    }
                    None if RESERVED.iter().any(|(n, _)| *n == item) => {
                        let why = RESERVED
                            .iter()
                            .find(|(n, _)| *n == item)
                            .map_or("", |r| r.1);
                        return Err(PipelineError::config(format!(
                            "--save: output {item:?} is not available yet: {why}"
                        )));
                    }
                    None => {
                        return Err(PipelineError::config(format!(
                            "--save: {} (or all, default)",
                            OUTPUTS.unknown(item)
                        )));
                    }
                },
            }
        }
        if set.contains(&Output::Amodal) && !set.contains(&Output::Boxes) {
            return Err(PipelineError::config(
                "--save amodal: the amodal silhouettes are written in boxes.json: add boxes",
            ));
        }
        Ok(OutputSet(set))
    }

    /// Refuse an output that `text` (`--save`) names and the scene cannot produce: `ids` of a
    /// 2D chart (`chart` true: it has no objects). An item reached through `all` is not refused
    /// (run.json says what was not written and why).
    pub fn check_applies(text: &str, chart: bool) -> Result<()> {
        if chart && text.split(',').any(|i| i.trim() == Output::Ids.name()) {
            return Err(PipelineError::config(
                "--save ids: a 2D chart has no objects to label; object and material ids are written for 3D scenes ([render]): leave ids out of --save",
            ));
        }
        Ok(())
    }

    pub fn contains(&self, o: Output) -> bool {
        self.0.contains(&o)
    }

    /// The labels a run must compute for these outputs (3D scenes): `None` when no output needs
    /// them (the label outputs, and depth and ids, which also get their raw-grid versions).
    pub fn label_request(&self) -> Option<camsim_render::LabelRequest> {
        let needs = Output::LABELS.iter().any(|o| self.contains(*o))
            || self.contains(Output::Depth)
            || self.contains(Output::Ids);
        needs.then_some(camsim_render::LabelRequest {
            normals: self.contains(Output::Normals),
            albedo: self.contains(Output::Albedo),
            amodal: self.contains(Output::Amodal),
        })
    }

    pub fn insert(&mut self, o: Output) {
        self.0.insert(o);
    }

    /// The names, comma-separated (as `--save` takes them).
    pub fn names(&self) -> String {
        self.0
            .iter()
            .map(|o| o.name())
            .collect::<Vec<_>>()
            .join(",")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The amodal silhouettes live in boxes.json: asked for without it, the run is refused.
    #[test]
    fn amodal_needs_boxes() {
        let e = OutputSet::parse("instances,amodal")
            .unwrap_err()
            .to_string();
        assert!(e.contains("amodal") && e.contains("add boxes"), "{e}");
        assert!(OutputSet::parse("boxes,amodal").is_ok());
        assert!(OutputSet::parse("all").is_ok());
    }

    /// Issue 25 item 7: `--save ids` on a 2D chart wrote nothing and said nothing.
    #[test]
    fn ids_named_for_a_chart_are_refused() {
        let e = OutputSet::check_applies("raw, ids", true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--save ids") && e.contains("3D"), "{e}");
        assert!(OutputSet::check_applies("raw,ids", false).is_ok());
        assert!(OutputSet::check_applies("all", true).is_ok());
    }

    #[test]
    fn parses_names_all_and_default_and_refuses_unknown_ones() {
        assert_eq!(OutputSet::parse("default").unwrap(), OutputSet::default());
        assert_eq!(OutputSet::parse("all").unwrap(), OutputSet::all());
        let s = OutputSet::parse("raw, irradiance,noise-free").unwrap();
        assert!(
            s.contains(Output::Raw)
                && s.contains(Output::Irradiance)
                && s.contains(Output::NoiseFree)
        );
        assert!(!s.contains(Output::Preview));
        assert_eq!(s.names(), "raw,irradiance,noise-free");
        let e = OutputSet::parse("raw,radience").unwrap_err().to_string();
        assert!(
            e.contains("--save") && e.contains("radience") && e.contains("radiance"),
            "{e}"
        );
        assert!(OutputSet::parse("").is_err());
    }
}
