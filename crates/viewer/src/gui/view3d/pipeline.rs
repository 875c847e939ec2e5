//! The 3-D view's wgpu side: the pipelines (triangles and lines, two-sided head light, see
//! `view3d.wgsl`), their buffers in egui_wgpu's callback resources, and one frame's paint
//! callback with its triangles sorted back to front.

use std::sync::Arc;

use eframe::egui;
use eframe::egui_wgpu::{self, wgpu};
use nurbs::Vec3;

use super::camera::Camera3d;
use super::geometry::{Geometry, VERTEX_FLOATS};

/// The wgpu side of the view: pipelines and buffers, kept in egui_wgpu's callback resources.
struct Renderer3d {
    triangles: wgpu::RenderPipeline,
    lines: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    buffers: Option<GpuBuffers>,
}

struct GpuBuffers {
    revision: u64,
    triangles: wgpu::Buffer,
    lines: wgpu::Buffer,
    line_vertices: u32,
    indices: wgpu::Buffer,
    index_capacity: u64,
    index_count: u32,
}

const SHADER: &str = include_str!("view3d.wgsl");

/// Builds the view's pipelines for `render_state` (its target format) and keeps them in its
/// callback resources; call once, when the app (or a snapshot harness) starts. Without it the
/// view draws its overlay only and says so.
pub fn install(render_state: &egui_wgpu::RenderState) {
    let device = &render_state.device;
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("view3d"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("view3d uniforms"),
        size: 80,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("view3d"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: std::num::NonZeroU64::new(80),
            },
            count: None,
        }],
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("view3d"),
        layout: &layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: uniforms.as_entire_binding(),
        }],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("view3d"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4];
    let pipeline = |topology: wgpu::PrimitiveTopology| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("view3d"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_main"),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: (VERTEX_FLOATS * 4) as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                })],
                compilation_options: wgpu::PipelineCompilationOptions::default(),
            },
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_main"),
                targets: &[Some(wgpu::ColorTargetState {
                    format: render_state.target_format,
                    blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                compilation_options: wgpu::PipelineCompilationOptions::default(),
            }),
            primitive: wgpu::PrimitiveState {
                topology,
                cull_mode: None,
                ..wgpu::PrimitiveState::default()
            },
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        })
    };
    let renderer = Renderer3d {
        triangles: pipeline(wgpu::PrimitiveTopology::TriangleList),
        lines: pipeline(wgpu::PrimitiveTopology::LineList),
        uniforms,
        bind_group,
        buffers: None,
    };
    render_state
        .renderer
        .write()
        .callback_resources
        .insert(renderer);
}

/// Whether [`install`] ran for the renderer of `ctx`'s painter; set by the app.
#[derive(Clone, Copy, Debug, Default)]
pub struct Installed(pub bool);

/// One frame of the view for the GPU.
pub(super) struct Draw3d {
    geometry: Arc<Geometry>,
    /// Triangle vertex indices, back to front.
    order: Vec<u32>,
    uniforms: [f32; 20],
}

impl Draw3d {
    /// The frame of `geometry` seen by `camera` in a viewport of `aspect` (width / height).
    pub(super) fn new(geometry: Arc<Geometry>, camera: &Camera3d, aspect: f32) -> Self {
        let light = camera.light_dir();
        let mut uniforms = [0.0f32; 20];
        uniforms[..16].copy_from_slice(&camera.view_proj(aspect).to_cols_array());
        uniforms[16..19].copy_from_slice(&light.to_array());
        Draw3d {
            order: back_to_front(&geometry, camera.eye()),
            geometry,
            uniforms,
        }
    }
}

fn bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

impl egui_wgpu::CallbackTrait for Draw3d {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        use wgpu::util::DeviceExt;
        let Some(r) = resources.get_mut::<Renderer3d>() else {
            return Vec::new();
        };
        queue.write_buffer(&r.uniforms, 0, &bytes(&self.uniforms));
        let g = &self.geometry;
        if r.buffers.as_ref().map(|b| b.revision) != Some(g.revision) {
            let vertex_buffer = |data: &[f32], label: &str| {
                // A buffer of at least one vertex: wgpu refuses empty vertex buffers.
                let mut data = data.to_vec();
                if data.is_empty() {
                    data.resize(VERTEX_FLOATS, 0.0);
                }
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: &bytes(&data),
                    usage: wgpu::BufferUsages::VERTEX,
                })
            };
            let index_capacity = (g.triangle_count().max(1) * 3 * 4) as u64;
            r.buffers = Some(GpuBuffers {
                revision: g.revision,
                triangles: vertex_buffer(&g.triangles, "view3d triangles"),
                lines: vertex_buffer(&g.lines, "view3d lines"),
                line_vertices: (g.lines.len() / VERTEX_FLOATS) as u32,
                indices: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("view3d indices"),
                    size: index_capacity,
                    usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                index_capacity,
                index_count: 0,
            });
        }
        if let Some(b) = &mut r.buffers {
            let data: Vec<u8> = self.order.iter().flat_map(|i| i.to_le_bytes()).collect();
            if (data.len() as u64) <= b.index_capacity {
                queue.write_buffer(&b.indices, 0, &data);
                b.index_count = self.order.len() as u32;
            } else {
                b.index_count = 0;
            }
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let Some(r) = resources.get::<Renderer3d>() else {
            return;
        };
        let Some(b) = &r.buffers else {
            return;
        };
        pass.set_bind_group(0, &r.bind_group, &[]);
        if b.index_count > 0 {
            pass.set_pipeline(&r.triangles);
            pass.set_vertex_buffer(0, b.triangles.slice(..));
            pass.set_index_buffer(b.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..b.index_count, 0, 0..1);
        }
        if b.line_vertices > 0 {
            pass.set_pipeline(&r.lines);
            pass.set_vertex_buffer(0, b.lines.slice(..));
            pass.draw(0..b.line_vertices, 0..1);
        }
    }
}

/// The triangles' vertex indices, farthest triangle first (a stable sort on the distance of
/// the centroids from the eye).
pub fn back_to_front(geometry: &Geometry, eye: Vec3) -> Vec<u32> {
    let mut order: Vec<(f32, u32)> = geometry
        .centroids
        .iter()
        .enumerate()
        .map(|(k, c)| ((*c - eye).length_squared(), k as u32))
        .collect();
    order.sort_by(|a, b| b.0.total_cmp(&a.0));
    order
        .into_iter()
        .flat_map(|(_, k)| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect()
}
