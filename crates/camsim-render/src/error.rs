//! Why a scene cannot be rendered (re-exported as `render::RenderError` and at the crate root).

use camsim_core::CoreError;

/// Why a scene cannot be rendered. Messages name the offending shape, material, light or setting.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No shapes and no lights.
    #[error("the scene is empty: it has no shapes and no lights")]
    EmptyScene,
    /// Nothing emits light.
    #[error("the scene has no light sources (no shape with an area light and no infinite light), so it would render black")]
    NoLights,
    /// The camera cannot form an image.
    #[error("camera: {0}")]
    Camera(String),
    /// A render setting is out of range.
    #[error("render settings: {0}")]
    Settings(String),
    /// A shape is malformed.
    #[error("shape {index} ('{name}'): {message}")]
    Shape {
        index: usize,
        name: String,
        message: String,
    },
    /// A material is malformed.
    #[error("material {index}: {message}")]
    Material { index: usize, message: String },
    /// A light is malformed.
    #[error("light {index}: {message}")]
    Light { index: usize, message: String },
    /// Memory guard or image construction.
    #[error(transparent)]
    Core(#[from] CoreError),
}
