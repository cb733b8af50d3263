//! Scene compilation ([`Tracer::new`]), in pbrt-v4's order of scene creation: materials (with
//! their textures and spectrum tables), media, a memory guard over the primitive count, the
//! shapes as BVH primitives with their area lights, the other lights, then the BVH (moving
//! shapes in their own, [`crate::motion`]) and the settings the integrator reads.

use super::Tracer;
use crate::bvh::Bvh;
use crate::curve::CurveStore;
use crate::error::RenderError;
use crate::geometry::{Aabb, MeshShading, Prim, PrimInfo, SphereClip, NO_LIGHT};
use crate::image_tex::ImageTex;
use crate::lights::{EmitImage, LightKind, Lights, NO_ALPHA, NO_IMAGE};
use crate::materials::{check_mix_cycles, compile_material, Mat};
use crate::math::V3;
use crate::media::MediaSet;
use crate::scene::{Geometry, SceneDescription, Shape};
use crate::spectral::{SpectrumTable, WavelengthSampler};

impl Tracer {
    /// Compile `scene` for the sampler `ws`.
    pub(crate) fn new(
        scene: &SceneDescription,
        ws: &WavelengthSampler,
    ) -> Result<Tracer, RenderError> {
        let mut tables: Vec<SpectrumTable> = Vec::new();
        let mut images: Vec<ImageTex> = Vec::new();
        crate::texture::take_footprint_needed();
        let materials = compile_materials(scene, ws, &mut tables, &mut images)?;
        let footprint_textures = crate::texture::take_footprint_needed();
        let media = compile_media(scene, ws)?;
        let n_prims = count_prims(scene)?;

        let mut geo = SceneGeometry::with_capacity(n_prims, scene.shapes.len());
        for (si, s) in scene.shapes.iter().enumerate() {
            geo.add_shape(si, s, &materials, ws, &mut tables)?;
        }
        geo.add_scene_lights(scene, ws, &mut tables)?;
        let SceneGeometry {
            prims,
            info,
            meshes,
            mut lights,
            scene_bounds,
            clips,
            curves,
            light_source,
        } = geo;
        if prims.is_empty() && lights.is_empty() {
            return Err(RenderError::EmptyScene);
        }
        if lights.is_empty() && !media.as_ref().is_some_and(|m| m.emissive()) {
            return Err(RenderError::NoLights);
        }
        // Scene radius for the infinite light's power (pbrt-v4 UniformInfiniteLight::Phi).
        let scene_radius = if prims.is_empty() {
            1.0
        } else {
            ((scene_bounds.max - scene_bounds.min) * 0.5)
                .length()
                .max(1e-3)
        };
        lights.finish(&tables, scene_radius);
        let (bvh, info, motion, tri_normals) =
            build_bvh(scene, prims, info, clips, curves, lights.list.len())?;
        // Lights chosen by their importance at each point (pbrt-v4's default `bvh` light
        // sampler) unless one moves: its bounds would hold for one pose only.
        if !motion.as_ref().is_some_and(|m| m.any_light_moves()) {
            lights.build_spatial();
        }

        let max_depth = if scene.settings.direct_only {
            scene.settings.max_depth.min(1)
        } else {
            scene.settings.max_depth
        };
        let shape_flip = scene.shapes.iter().map(|s| s.reverse_orientation).collect();
        let has_interface = materials.iter().any(|m| matches!(m, Mat::Interface));
        let has_alpha = materials
            .iter()
            .any(|m| matches!(m, Mat::AlphaMasked { .. }));
        let rr_depth = scene.settings.russian_roulette_depth.max(1);
        Ok(Tracer {
            bvh,
            info,
            tri_normals,
            meshes,
            materials,
            tables,
            images,
            lights,
            max_depth,
            rr_depth,
            shape_flip,
            has_interface,
            has_alpha,
            footprint: crate::bump::Footprint::new(&scene.camera, scene.settings.samples_per_pixel),
            footprint_textures,
            layered_exit_pbrt_v4: scene.settings.layered_exit_weight
                == crate::scene::LayeredExitWeight::PbrtV4,
            media,
            light_source,
            motion,
        })
    }
}

/// The scene's materials, compiled in order (their spectra into `tables`, their images into
/// `images`), `mix` cycles refused.
fn compile_materials(
    scene: &SceneDescription,
    ws: &WavelengthSampler,
    tables: &mut Vec<SpectrumTable>,
    images: &mut Vec<ImageTex>,
) -> Result<Vec<Mat>, RenderError> {
    let mut materials = Vec::with_capacity(scene.materials.len());
    for (mi, m) in scene.materials.iter().enumerate() {
        let mat = compile_material(m, mi, scene.materials.len(), ws, tables, images)?;
        materials.push(mat);
    }
    check_mix_cycles(&materials)?;
    Ok(materials)
}

/// The scene's participating media, if a ray can be in one.
fn compile_media(
    scene: &SceneDescription,
    ws: &WavelengthSampler,
) -> Result<Option<Box<MediaSet>>, RenderError> {
    // Media do not move (pbrt-v4 creates them with the start transform); the shapes bounding
    // them, the lights and the camera may: the volumetric tracer traces, transmits and samples
    // lights at the path's time (`integrator::volpath`).
    MediaSet::compile(scene, ws)
}

/// The number of BVH primitives the scene makes (curves as their split segments).
pub(crate) fn prim_count(scene: &SceneDescription) -> u64 {
    scene
        .shapes
        .iter()
        .map(|s| match &s.geometry {
            Geometry::Triangles { indices, .. } => indices.len() as u64,
            Geometry::Sphere { .. } | Geometry::PartialSphere { .. } => 1,
            Geometry::Curves(c) => c.segments() as u64 * (1u64 << c.split_depth.min(12)),
        })
        .fold(0u64, u64::saturating_add)
}

/// [`prim_count`], refused before the BVH is allocated when it is more than the renderer
/// supports or its BVH would not fit in memory (a render checks its whole peak first,
/// [`crate::budget`]; this guards the tracers made for labels alone).
fn count_prims(scene: &SceneDescription) -> Result<u64, RenderError> {
    let n_prims = prim_count(scene);
    camsim_core::mem::MemoryBudget::new(format!("a BVH over {n_prims} primitives"))
        .bytes(
            "BVH",
            n_prims.saturating_mul(crate::budget::BVH_BYTES_PER_PRIM),
        )
        .check("use a scene with fewer shapes or a coarser tessellation")?;
    if n_prims > crate::bvh::MAX_PRIMS as u64 {
        return Err(RenderError::Settings(format!(
            "{n_prims} primitives is more than the renderer supports"
        )));
    }
    Ok(n_prims)
}

/// A malformed shape `si`.
fn shape_err(si: usize, s: &Shape, message: String) -> RenderError {
    RenderError::Shape {
        index: si,
        name: s.name.clone().unwrap_or_default(),
        message,
    }
}

/// What a shape's area light gives each of its emitting primitives.
#[derive(Clone, Copy)]
struct Emission {
    /// The radiance's spectrum table and two-sidedness (`None`: the shape does not emit).
    table: Option<(u32, bool)>,
    /// The emission image (`Lights::images`), or [`NO_IMAGE`].
    image: u32,
    /// The shape's alpha-masked material, or [`NO_ALPHA`].
    alpha_mat: u32,
}

/// The primitives, per-primitive records and lights built from the scene's shapes and lights.
struct SceneGeometry {
    prims: Vec<Prim>,
    info: Vec<PrimInfo>,
    meshes: Vec<Option<MeshShading>>,
    lights: Lights,
    scene_bounds: Aabb,
    clips: Vec<SphereClip>,
    curves: CurveStore,
    /// The scene object each compiled light comes from (shape index, or shapes + light index).
    light_source: Vec<u32>,
}

impl SceneGeometry {
    fn with_capacity(n_prims: u64, n_shapes: usize) -> SceneGeometry {
        SceneGeometry {
            prims: Vec::with_capacity(n_prims as usize),
            info: Vec::with_capacity(n_prims as usize),
            meshes: Vec::with_capacity(n_shapes),
            lights: Lights::default(),
            scene_bounds: Aabb::EMPTY,
            clips: Vec::new(),
            curves: CurveStore::default(),
            light_source: Vec::new(),
        }
    }

    /// Shape `si`: its emission, then its primitives.
    fn add_shape(
        &mut self,
        si: usize,
        s: &Shape,
        materials: &[Mat],
        ws: &WavelengthSampler,
        tables: &mut Vec<SpectrumTable>,
    ) -> Result<(), RenderError> {
        self.light_source
            .resize(self.lights.list.len(), si.saturating_sub(1) as u32);
        if s.material >= materials.len() {
            return Err(shape_err(
                si,
                s,
                format!(
                    "material index {} but the scene has {} materials",
                    s.material,
                    materials.len()
                ),
            ));
        }
        let emission = self.emission(si, s, materials, ws, tables)?;
        match &s.geometry {
            Geometry::Triangles {
                positions,
                indices,
                uvs,
                normals,
                colors,
                uvs1,
                tangents,
            } => self.add_triangles(
                si,
                s,
                positions,
                indices,
                uvs,
                normals,
                VertexExtras {
                    colors,
                    uvs1,
                    tangents,
                },
                emission,
            ),
            Geometry::Sphere { center, radius } => {
                self.add_sphere(si, s, *center, *radius, emission)
            }
            Geometry::PartialSphere {
                center,
                radius,
                axes,
                z_min,
                z_max,
                phi_max_deg,
            } => self.add_partial_sphere(
                si,
                s,
                *center,
                *radius,
                axes,
                [*z_min, *z_max, *phi_max_deg],
                emission,
            ),
            Geometry::Curves(c) => {
                c.validate()
                    .map_err(|e| shape_err(si, s, format!("curve: {e}")))?;
                if s.area_light.is_some() {
                    return Err(shape_err(
                        si,
                        s,
                        "area lights on curves are not supported (pbrt-v4 cannot sample curves either)".into(),
                    ));
                }
                let (lo, hi) = c.bounds_m();
                self.scene_bounds.grow_point(V3::from_f64(lo));
                self.scene_bounds.grow_point(V3::from_f64(hi));
                let (prims, info) = (&mut self.prims, &mut self.info);
                crate::curve::add_prims(&mut self.curves, c, s.reverse_orientation, |seg, prim| {
                    prims.push(prim);
                    info.push(PrimInfo {
                        shape: si as u32,
                        tri: seg,
                        material: s.material as u32,
                        light: NO_LIGHT,
                    });
                });
                self.meshes.push(None);
                Ok(())
            }
        }
    }

    /// Shape `si`'s area light: its radiance table and its emission image (pbrt-v4 `filename`:
    /// an image over the uv of a triangle mesh or of a (partial) sphere).
    fn emission(
        &mut self,
        si: usize,
        s: &Shape,
        materials: &[Mat],
        ws: &WavelengthSampler,
        tables: &mut Vec<SpectrumTable>,
    ) -> Result<Emission, RenderError> {
        // An alpha-masked emitter (pbrt-v4 `DiffuseAreaLight::AlphaMasked`): rays skip the
        // points its test rejects (as on any shape) and light samples there carry nothing.
        let alpha_mat = if matches!(materials[s.material], Mat::AlphaMasked { .. }) {
            s.material as u32
        } else {
            NO_ALPHA
        };
        let table = match &s.area_light {
            Some(al) => {
                if let Err(e) = al.radiance.require_non_negative("area light radiance") {
                    return Err(shape_err(si, s, e.to_string()));
                }
                tables.push(SpectrumTable::new(&al.radiance, 1.0, ws));
                Some(((tables.len() - 1) as u32, al.two_sided))
            }
            None => None,
        };
        let mut image = NO_IMAGE;
        if let Some(im) = s.area_light.as_ref().and_then(|al| al.image.as_ref()) {
            if im.width == 0 || im.height == 0 || im.rgb.len() != im.width * im.height {
                return Err(shape_err(
                    si,
                    s,
                    format!(
                        "area light image of {} x {} pixels has {} texels",
                        im.width,
                        im.height,
                        im.rgb.len()
                    ),
                ));
            }
            if im
                .rgb
                .iter()
                .flatten()
                .any(|v| !(v.is_finite() && *v >= 0.0))
            {
                return Err(shape_err(
                    si,
                    s,
                    "area light image has negative or non-finite texels".into(),
                ));
            }
            let mean_rgb = im
                .rgb
                .iter()
                .map(|c| (c[0] + c[1] + c[2]) as f64 / 3.0)
                .sum::<f64>()
                / im.rgb.len() as f64;
            let tex = ImageTex {
                width: im.width,
                height: im.height,
                rgb: std::sync::Arc::clone(&im.rgb),
                uscale: 1.0,
                vscale: 1.0,
                udelta: 0.0,
                vdelta: 0.0,
                // pbrt-v4 `DiffuseAreaLight::L` bilerps with `Image`'s default clamp.
                wrap: crate::scene::WrapMode::Clamp,
                filter: crate::scene::TexelFilter::Bilinear,
                mip: None,
            };
            self.lights.images.push(EmitImage {
                tex,
                mean_rgb: mean_rgb as f32,
                uv1: im.uv1,
            });
            image = (self.lights.images.len() - 1) as u32;
        }
        Ok(Emission {
            table,
            image,
            alpha_mat,
        })
    }

    /// Primitive `tri` (triangle or curve segment; 0 for a sphere) of shape `si`, emitter `light`.
    fn push_prim(&mut self, prim: Prim, si: usize, tri: u32, s: &Shape, light: u32) {
        self.prims.push(prim);
        self.info.push(PrimInfo {
            shape: si as u32,
            tri,
            material: s.material as u32,
            light,
        });
    }

    /// Emitter `light`'s image and alpha from its shape's `emission`.
    fn tag_emitter(&mut self, light: u32, emission: Emission) {
        let e = &mut self.lights.list[light as usize];
        e.image = emission.image;
        e.alpha_mat = emission.alpha_mat;
    }

    /// A triangle mesh: one primitive per triangle, one emitter per emitting triangle (pbrt-v4
    /// makes every triangle its own shape), and its shading data when it has uv or normals.
    #[allow(clippy::too_many_arguments)]
    fn add_triangles(
        &mut self,
        si: usize,
        s: &Shape,
        positions: &[[f64; 3]],
        indices: &[[u32; 3]],
        uvs: &Option<Vec<[f32; 2]>>,
        normals: &Option<Vec<[f64; 3]>>,
        extras: VertexExtras<'_>,
        emission: Emission,
    ) -> Result<(), RenderError> {
        if let Some(i) = positions
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(shape_err(
                si,
                s,
                format!("vertex {i} has a non-finite coordinate"),
            ));
        }
        if let Some(uv) = uvs {
            if uv.len() != positions.len() {
                return Err(shape_err(
                    si,
                    s,
                    format!("{} uvs for {} vertices", uv.len(), positions.len()),
                ));
            }
        }
        if let Some(n) = normals {
            if n.len() != positions.len() {
                return Err(shape_err(
                    si,
                    s,
                    format!("{} normals for {} vertices", n.len(), positions.len()),
                ));
            }
        }
        // The per-vertex arrays are indexed as the positions are.
        let counts = [
            ("vertex colours", extras.colors.as_ref().map(Vec::len)),
            ("second-set uvs", extras.uvs1.as_ref().map(Vec::len)),
            ("tangents", extras.tangents.as_ref().map(Vec::len)),
        ];
        for (what, n) in counts {
            if let Some(n) = n.filter(|n| *n != positions.len()) {
                return Err(shape_err(
                    si,
                    s,
                    format!("{n} {what} for {} vertices", positions.len()),
                ));
            }
        }
        let colors: Option<Vec<[f32; 4]>> = extras.colors.as_ref().map(|c| {
            c.iter()
                .map(|v| v.map(|x| if x.is_finite() { x.max(0.0) } else { 1.0 }))
                .collect()
        });
        let uvs1: Option<Vec<[f32; 2]>> = extras.uvs1.as_ref().map(|t| {
            t.iter()
                .map(|v| v.map(|x| if x.is_finite() { x } else { 0.0 }))
                .collect()
        });
        // Unit tangents (a zero or non-finite one falls back to dp/du at the hit).
        let tangents: Option<Vec<(V3, f32)>> = extras.tangents.as_ref().map(|t| {
            t.iter()
                .map(|v| {
                    let d = V3::new(v[0], v[1], v[2]);
                    let l = d.length();
                    if l > 0.0 && l.is_finite() {
                        (d / l, if v[3] < 0.0 { -1.0 } else { 1.0 })
                    } else {
                        (V3::splat(0.0), 1.0)
                    }
                })
                .collect()
        });
        let emit_uv1 = self
            .lights
            .images
            .get(emission.image as usize)
            .is_some_and(|im| im.uv1);
        let pos: Vec<V3> = positions.iter().map(|p| V3::from_f64(*p)).collect();
        let nrm: Option<Vec<V3>> = normals.as_ref().map(|n| {
            n.iter()
                .map(|v| V3::from_f64(*v).normalize())
                .map(|v| if v.is_finite() { v } else { V3::splat(0.0) })
                .collect()
        });
        for (ti, tri) in indices.iter().enumerate() {
            if let Some(bad) = tri.iter().find(|i| **i as usize >= positions.len()) {
                return Err(shape_err(
                    si,
                    s,
                    format!(
                        "triangle {ti} uses vertex {bad} but there are {} vertices",
                        positions.len()
                    ),
                ));
            }
            let (p0, p1, p2) = (
                pos[tri[0] as usize],
                pos[tri[1] as usize],
                pos[tri[2] as usize],
            );
            let (e1, e2) = (p1 - p0, p2 - p0);
            self.scene_bounds.grow_point(p0);
            self.scene_bounds.grow_point(p1);
            self.scene_bounds.grow_point(p2);
            let mut light = NO_LIGHT;
            if let Some((table, two_sided)) = emission.table {
                let c = e1.cross(e2);
                let area = 0.5 * c.length();
                if area > 0.0 && area.is_finite() {
                    // Emitting side (pbrt-v4 Triangle): the face normal, turned toward
                    // the vertex normals if given, else flipped by ReverseOrientation.
                    let mut n = c.normalize();
                    if let Some(nv) = &nrm {
                        let avg = nv[tri[0] as usize] + nv[tri[1] as usize] + nv[tri[2] as usize];
                        n = n.face_forward(avg);
                    } else if s.reverse_orientation {
                        n = -n;
                    }
                    light = self.lights.push(
                        LightKind::Tri {
                            p0,
                            e1,
                            e2,
                            n,
                            area,
                        },
                        table,
                        two_sided,
                    );
                    // The triangle's uvs (pbrt-v4 defaults (0,0), (1,0), (1,1)), as
                    // `surface` interpolates them at a hit.
                    self.tag_emitter(light, emission);
                    // An image on the second uv set reads that set (`Lights::hit_uv`).
                    let set = if emit_uv1 {
                        uvs1.as_ref().or(uvs.as_ref())
                    } else {
                        uvs.as_ref()
                    };
                    self.lights.list[light as usize].uvs = match set {
                        Some(t) => [t[tri[0] as usize], t[tri[1] as usize], t[tri[2] as usize]],
                        None => [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
                    };
                }
            }
            self.push_prim(Prim::Tri { p0, e1, e2 }, si, ti as u32, s, light);
        }
        if uvs.is_some()
            || normals.is_some()
            || colors.is_some()
            || uvs1.is_some()
            || tangents.is_some()
        {
            self.meshes.push(Some(MeshShading {
                indices: indices.to_vec(),
                uvs: uvs.clone(),
                normals: nrm,
                colors,
                uvs1,
                tangents,
            }));
        } else {
            self.meshes.push(None);
        }
        Ok(())
    }

    /// A full sphere: one primitive; as an emitter sampled by its visible cone, or by area as a
    /// full zone when an alpha cut-out shows its far side.
    fn add_sphere(
        &mut self,
        si: usize,
        s: &Shape,
        center: [f64; 3],
        radius: f64,
        emission: Emission,
    ) -> Result<(), RenderError> {
        if !(center.iter().all(|v| v.is_finite()) && radius > 0.0 && radius.is_finite()) {
            return Err(shape_err(
                si,
                s,
                format!("sphere at {center:?} with radius {radius} m is invalid"),
            ));
        }
        let c = V3::from_f64(center);
        let r = radius as f32;
        self.scene_bounds.grow_point(c - V3::splat(r));
        self.scene_bounds.grow_point(c + V3::splat(r));
        let mut light = NO_LIGHT;
        if let Some((table, two_sided)) = emission.table {
            let kind = if emission.alpha_mat == NO_ALPHA {
                LightKind::Sphere {
                    center: c,
                    radius: r,
                    inward: s.reverse_orientation,
                }
            } else {
                // Through alpha cut-outs the far side's inner face shows, which cone
                // sampling (near side only) never picks: sample the whole sphere by
                // area, as a zone with the full range (same uv, `lights::zone_uv`).
                let (ex, ey, ez) = (
                    V3::new(1.0, 0.0, 0.0),
                    V3::new(0.0, 1.0, 0.0),
                    V3::new(0.0, 0.0, 1.0),
                );
                let clip = SphereClip {
                    ex,
                    ey,
                    ez,
                    z_min: -r,
                    z_max: r,
                    phi_max: 2.0 * std::f32::consts::PI,
                };
                LightKind::SphereZone {
                    center: c,
                    radius: r,
                    clip,
                    area: 4.0 * std::f32::consts::PI * r * r,
                    inward: s.reverse_orientation,
                }
            };
            light = self.lights.push(kind, table, two_sided);
            self.tag_emitter(light, emission);
        }
        self.push_prim(
            Prim::Sphere {
                center: c,
                radius: r,
            },
            si,
            0,
            s,
            light,
        );
        self.meshes.push(None);
        Ok(())
    }

    /// A partial sphere (`range`: z_min, z_max in m along its `axes[2]`, phi_max in degrees):
    /// one primitive with its clip; as an emitter a sphere zone sampled by area.
    #[allow(clippy::too_many_arguments)]
    fn add_partial_sphere(
        &mut self,
        si: usize,
        s: &Shape,
        center: [f64; 3],
        radius: f64,
        axes: &[[f64; 3]; 3],
        range: [f64; 3],
        emission: Emission,
    ) -> Result<(), RenderError> {
        let [z_min, z_max, phi_max_deg] = range;
        let axes_ok = axes.iter().all(|a| {
            a.iter().all(|v| v.is_finite())
                && ((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - 1.0).abs() < 1e-3
        });
        if !(center.iter().all(|v| v.is_finite()) && radius > 0.0 && radius.is_finite() && axes_ok)
        {
            return Err(shape_err(si, s, format!("partial sphere at {center:?} with radius {radius} m and axes {axes:?} is invalid")));
        }
        if !(z_min >= -radius
            && z_max <= radius
            && z_min < z_max
            && phi_max_deg > 0.0
            && phi_max_deg <= 360.0)
        {
            return Err(shape_err(si, s, format!(
                "partial sphere z range [{z_min}, {z_max}] m (radius {radius} m) or phi_max {phi_max_deg} deg is invalid"
            )));
        }
        let c = V3::from_f64(center);
        let r = radius as f32;
        let clip = SphereClip {
            ex: V3::from_f64(axes[0]).normalize(),
            ey: V3::from_f64(axes[1]).normalize(),
            ez: V3::from_f64(axes[2]).normalize(),
            z_min: z_min as f32,
            z_max: z_max as f32,
            phi_max: phi_max_deg.to_radians() as f32,
        };
        self.scene_bounds.grow_point(c - V3::splat(r));
        self.scene_bounds.grow_point(c + V3::splat(r));
        let mut light = NO_LIGHT;
        if let Some((table, two_sided)) = emission.table {
            // pbrt-v4 Sphere::Area: phi_max r (z_max - z_min).
            let area = clip.phi_max * r * (clip.z_max - clip.z_min);
            light = self.lights.push(
                LightKind::SphereZone {
                    center: c,
                    radius: r,
                    clip,
                    area,
                    inward: s.reverse_orientation,
                },
                table,
                two_sided,
            );
            self.tag_emitter(light, emission);
        }
        let prim = Prim::PartialSphere {
            center: c,
            radius: r,
            clip: self.clips.len() as u32,
        };
        self.clips.push(clip);
        self.push_prim(prim, si, 0, s, light);
        self.meshes.push(None);
        Ok(())
    }

    /// The scene's lights that are not shapes (point, spot, distant, infinite, ...).
    fn add_scene_lights(
        &mut self,
        scene: &SceneDescription,
        ws: &WavelengthSampler,
        tables: &mut Vec<SpectrumTable>,
    ) -> Result<(), RenderError> {
        self.light_source.resize(
            self.lights.list.len(),
            scene.shapes.len().saturating_sub(1) as u32,
        );
        for (li, l) in scene.lights.iter().enumerate() {
            self.lights
                .add_scene_light(l, ws, tables)
                .map_err(|message| RenderError::Light { index: li, message })?;
            self.light_source
                .resize(self.lights.list.len(), (scene.shapes.len() + li) as u32);
        }
        Ok(())
    }
}

/// What [`build_bvh`] makes: the static BVH, the per-primitive records in BVH order (moving
/// ones after the static ones), the moving part, and each static primitive's unit normal.
type BuiltBvh = (
    Bvh,
    Vec<PrimInfo>,
    Option<Box<crate::motion::MotionTracer>>,
    Vec<V3>,
);

/// The BVH over the static primitives; moving shapes get their own BVHs (`crate::motion`), a
/// static scene keeps every primitive.
fn build_bvh(
    scene: &SceneDescription,
    mut prims: Vec<Prim>,
    mut info: Vec<PrimInfo>,
    clips: Vec<SphereClip>,
    curves: CurveStore,
    n_lights: usize,
) -> Result<BuiltBvh, RenderError> {
    let moving = crate::motion::take_moving(scene, &mut prims, &mut info, &clips, &curves)?;
    let mut bvh = Bvh::build_with_curves(prims, curves);
    bvh.clips = clips;
    let mut info: Vec<PrimInfo> = bvh.ids.iter().map(|&i| info[i as usize]).collect();
    let motion =
        crate::motion::MotionTracer::build(scene, moving, &mut info, n_lights)?.map(Box::new);
    let tri_normals: Vec<V3> = bvh
        .prims
        .iter()
        .map(|p| match *p {
            Prim::Tri { e1, e2, .. } => e1.cross(e2).normalize(),
            Prim::Sphere { .. } | Prim::PartialSphere { .. } | Prim::Curve { .. } => V3::splat(0.0),
        })
        .collect();
    Ok((bvh, info, motion, tri_normals))
}

/// A triangle mesh's optional per-vertex arrays beyond uvs and normals (glTF `COLOR_0`, a
/// second `TEXCOORD_n`, `TANGENT`).
struct VertexExtras<'a> {
    colors: &'a Option<Vec<[f32; 4]>>,
    uvs1: &'a Option<Vec<[f32; 2]>>,
    tangents: &'a Option<Vec<[f32; 4]>>,
}
