//! Bind group layouts read off a composed pass's naga module (reflection, as vello derives
//! its layouts): every resource binding the entry points reach, its type and the stages
//! that use it. The WGSL is the one statement of what a pass binds; nothing here repeats it.

use std::collections::BTreeMap;

use naga::{AddressSpace, ImageClass, ImageDimension, ScalarKind, ShaderStage, TypeInner};

use super::bindings::Binding;
use super::error::RenderError;
use crate::compose::ComposedPass;
use crate::gpu::{Gpu, LayoutObjects};

/// The layout entries of each bind group a pass uses, by group index, in binding order.
pub type GroupEntries = BTreeMap<u32, Vec<wgpu::BindGroupLayoutEntry>>;

/// The bindings of `pass`'s module that its entry points use.
pub fn layout_entries(pass: &ComposedPass) -> Result<GroupEntries, RenderError> {
    let module = &pass.module;
    let mut groups = GroupEntries::new();
    for (handle, var) in module.global_variables.iter() {
        let Some(slot) = &var.binding else { continue };
        let mut visibility = wgpu::ShaderStages::NONE;
        for (i, entry) in module.entry_points.iter().enumerate() {
            if !pass.info.get_entry_point(i)[handle].is_empty() {
                visibility |= match entry.stage {
                    ShaderStage::Vertex => wgpu::ShaderStages::VERTEX,
                    ShaderStage::Fragment => wgpu::ShaderStages::FRAGMENT,
                    _ => wgpu::ShaderStages::COMPUTE,
                };
            }
        }
        if visibility.is_empty() {
            continue;
        }
        let unsupported = |what: &str| {
            RenderError::Reflection(format!(
                "pass `{}`: binding @group({}) @binding({}) is {what}, which clusterlab does not bind",
                pass.name, slot.group, slot.binding
            ))
        };
        let ty = match (&module.types[var.ty].inner, var.space) {
            (_, AddressSpace::Uniform) => wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            (_, AddressSpace::Storage { access }) => wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage {
                    read_only: !access.contains(naga::StorageAccess::STORE),
                },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            (TypeInner::Sampler { comparison: false }, AddressSpace::Handle) => {
                wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)
            }
            (
                TypeInner::Image {
                    dim,
                    arrayed,
                    class,
                },
                AddressSpace::Handle,
            ) => {
                let view_dimension = match (dim, arrayed) {
                    (ImageDimension::D2, false) => wgpu::TextureViewDimension::D2,
                    (ImageDimension::D2, true) => wgpu::TextureViewDimension::D2Array,
                    _ => return Err(unsupported("a texture other than 2D")),
                };
                match *class {
                    // The one arrayed texture, the base colour textures, is filtered; every
                    // other texture is read with `textureLoad`: unfilterable.
                    ImageClass::Sampled { kind, multi } => wgpu::BindingType::Texture {
                        sample_type: match kind {
                            ScalarKind::Float => wgpu::TextureSampleType::Float {
                                filterable: *arrayed,
                            },
                            ScalarKind::Uint => wgpu::TextureSampleType::Uint,
                            ScalarKind::Sint => wgpu::TextureSampleType::Sint,
                            _ => return Err(unsupported("a texture of booleans")),
                        },
                        view_dimension,
                        multisampled: multi,
                    },
                    ImageClass::Depth { multi } => wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension,
                        multisampled: multi,
                    },
                    ImageClass::Storage { format, access } => wgpu::BindingType::StorageTexture {
                        access: storage_access(access),
                        format: storage_format(format)
                            .ok_or_else(|| unsupported(&format!("a {format:?} storage image")))?,
                        view_dimension,
                    },
                    ImageClass::External => return Err(unsupported("an external texture")),
                }
            }
            _ => return Err(unsupported("not a buffer, a sampler or a 2D texture")),
        };
        groups
            .entry(slot.group)
            .or_default()
            .push(wgpu::BindGroupLayoutEntry {
                binding: slot.binding,
                visibility,
                ty,
                count: None,
            });
    }
    for entries in groups.values_mut() {
        entries.sort_by_key(|e| e.binding);
    }
    Ok(groups)
}

fn storage_access(access: naga::StorageAccess) -> wgpu::StorageTextureAccess {
    let read = access.contains(naga::StorageAccess::LOAD);
    let write = access.contains(naga::StorageAccess::STORE);
    match (read, write) {
        (true, true) => wgpu::StorageTextureAccess::ReadWrite,
        (true, false) => wgpu::StorageTextureAccess::ReadOnly,
        _ => wgpu::StorageTextureAccess::WriteOnly,
    }
}

/// The wgpu format of a storage image format the shaders use.
fn storage_format(f: naga::StorageFormat) -> Option<wgpu::TextureFormat> {
    use naga::StorageFormat as S;
    use wgpu::TextureFormat as T;
    Some(match f {
        S::Rgba32Float => T::Rgba32Float,
        S::Rgba16Float => T::Rgba16Float,
        S::Rgba8Unorm => T::Rgba8Unorm,
        S::R32Float => T::R32Float,
        S::R32Uint => T::R32Uint,
        S::Rgba32Uint => T::Rgba32Uint,
        _ => return None,
    })
}

/// One binding of a pass: where it sits, and what its module declares it as.
pub struct Slot {
    pub group: u32,
    pub binding: u32,
    pub name: Binding,
}

/// The bind group layouts of a pass and the pipeline layout made of them; a group the pass
/// does not use is a gap. Made once per device for each distinct WGSL.
pub struct PassLayout {
    entries: GroupEntries,
    /// What each binding is, by its declared name (`ComposedPass::slot_names`).
    names: BTreeMap<(u32, u32), Binding>,
    groups: Vec<Option<wgpu::BindGroupLayout>>,
    pub pipeline: wgpu::PipelineLayout,
}

impl PassLayout {
    /// The layout of `pass`, from its module.
    pub fn of(gpu: &Gpu, pass: &ComposedPass) -> Result<Self, RenderError> {
        let entries = layout_entries(pass)?;
        let names = declared(pass)?;
        let count = entries.keys().next_back().map_or(0, |g| g + 1);
        let objects = gpu.pass_layout(&pass.wgsl, || {
            let groups: Vec<Option<wgpu::BindGroupLayout>> = (0..count)
                .map(|g| {
                    entries.get(&g).map(|e| {
                        gpu.device
                            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                                label: Some(&pass.name),
                                entries: e,
                            })
                    })
                })
                .collect();
            let refs: Vec<Option<&wgpu::BindGroupLayout>> =
                groups.iter().map(Option::as_ref).collect();
            let pipeline = gpu
                .device
                .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(&pass.name),
                    bind_group_layouts: &refs,
                    immediate_size: 0,
                });
            LayoutObjects { groups, pipeline }
        })?;
        Ok(Self {
            entries,
            names,
            groups: objects.groups,
            pipeline: objects.pipeline,
        })
    }

    /// The bind groups of this layout, each binding filled by `resource(slot)`. A slot
    /// `resource` has nothing for is an error naming it.
    pub fn bind_groups<'r>(
        &self,
        gpu: &Gpu,
        pass: &str,
        resource: impl Fn(&Slot) -> Option<wgpu::BindingResource<'r>>,
    ) -> Result<Vec<Option<wgpu::BindGroup>>, RenderError> {
        let entries = &self.entries;
        self.groups
            .iter()
            .enumerate()
            .map(|(g, layout)| {
                let (Some(layout), Some(slots)) = (layout, entries.get(&(g as u32))) else {
                    return Ok(None);
                };
                let bound = slots
                    .iter()
                    .map(|slot| {
                        let name = self.names[&(g as u32, slot.binding)];
                        let at = Slot {
                            group: g as u32,
                            binding: slot.binding,
                            name,
                        };
                        let resource = resource(&at).ok_or_else(|| {
                            RenderError::Reflection(format!(
                                "pass `{pass}` binds @group({g}) @binding({}) `{}`, which no resource fills",
                                slot.binding,
                                name.name()
                            ))
                        })?;
                        Ok(wgpu::BindGroupEntry {
                            binding: slot.binding,
                            resource,
                        })
                    })
                    .collect::<Result<Vec<_>, RenderError>>()?;
                Ok(Some(gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(pass),
                    layout,
                    entries: &bound,
                })))
            })
            .collect()
    }
}

/// What each binding of `pass` is, by (group, binding): an error for a declared name that
/// is no `Binding`.
pub fn declared(pass: &ComposedPass) -> Result<BTreeMap<(u32, u32), Binding>, RenderError> {
    pass.slot_names
        .iter()
        .map(|(&at, name)| Ok((at, Binding::declared(&pass.name, name)?)))
        .collect()
}

/// How a buffer binding of a pass lays out its bytes, read off the module's types: the
/// size of one element (an array's stride, or the whole type), and each struct member's
/// byte offset by its declared name.
#[derive(Clone, Debug, PartialEq)]
pub struct BufferLayout {
    pub element_bytes: u64,
    pub members: Vec<(String, u64)>,
}

impl BufferLayout {
    /// The layout of the binding `pass` declares as `name`, if it has one.
    pub fn of(pass: &ComposedPass, name: Binding) -> Option<Self> {
        let module = &pass.module;
        let (&(group, binding), _) = pass.slot_names.iter().find(|(_, n)| *n == name.name())?;
        let (_, var) = module.global_variables.iter().find(|(_, v)| {
            v.binding
                .as_ref()
                .is_some_and(|b| b.group == group && b.binding == binding)
        })?;
        let ty = &module.types[var.ty].inner;
        let (element_bytes, members) = match ty {
            TypeInner::Array { stride, .. } => (*stride as u64, Vec::new()),
            TypeInner::Struct { members, span } => (
                *span as u64,
                members
                    .iter()
                    .filter_map(|m| Some((m.name.clone()?, m.offset as u64)))
                    .collect(),
            ),
            other => (other.size(module.to_ctx()) as u64, Vec::new()),
        };
        Some(Self {
            element_bytes,
            members,
        })
    }

    /// The byte offset of member `name`.
    pub fn offset(&self, name: &str) -> Option<u64> {
        self.members
            .iter()
            .find(|(n, _)| n == name)
            .map(|&(_, at)| at)
    }
}

/// How many bytes each storage buffer the frame's passes declare takes, by its declared
/// name, read off their modules: its fixed part and the stride of its runtime-sized array
/// (a bare array: none and its stride; a struct ending in one: the bytes before it and its
/// stride; any other type: its size). Buffers are sized from these, so no element size is
/// written in Rust.
#[derive(Clone, Debug, Default)]
pub struct BufferSizes(BTreeMap<Binding, (u64, u64)>);

impl BufferSizes {
    /// The storage buffers `passes` declare (one name, one type, in every pass).
    pub fn of<'a>(passes: impl IntoIterator<Item = &'a ComposedPass>) -> Result<Self, RenderError> {
        let mut sizes = BTreeMap::new();
        for pass in passes {
            let module = &pass.module;
            for (_, var) in module.global_variables.iter() {
                let Some(slot) = &var.binding else { continue };
                if !matches!(var.space, AddressSpace::Storage { .. }) {
                    continue;
                }
                let Some(name) = pass.slot_names.get(&(slot.group, slot.binding)) else {
                    continue;
                };
                let name = Binding::declared(&pass.name, name)?;
                let runtime = |ty: naga::Handle<naga::Type>| match module.types[ty].inner {
                    TypeInner::Array {
                        size: naga::ArraySize::Dynamic,
                        stride,
                        ..
                    } => Some(stride as u64),
                    _ => None,
                };
                let size = match &module.types[var.ty].inner {
                    TypeInner::Struct { members, span } => match members.last() {
                        Some(last) => match runtime(last.ty) {
                            Some(stride) => (last.offset as u64, stride),
                            None => (*span as u64, 0),
                        },
                        None => (*span as u64, 0),
                    },
                    _ => match runtime(var.ty) {
                        Some(stride) => (0, stride),
                        None => (module.types[var.ty].inner.size(module.to_ctx()) as u64, 0),
                    },
                };
                sizes.insert(name, size);
            }
        }
        Ok(Self(sizes))
    }

    /// The bytes of buffer `name` holding `count` elements of its array, if a pass
    /// declares it.
    pub fn bytes(&self, name: Binding, count: u64) -> Option<u64> {
        self.0.get(&name).map(|&(fixed, each)| fixed + each * count)
    }

    /// The bytes of buffer `name` holding `count` elements, at least one: the least a
    /// binding of a runtime-sized array takes. 0 where no pass declares it (nothing binds
    /// it).
    pub fn bindable(&self, name: Binding, count: u64) -> u64 {
        self.bytes(name, count.max(1)).unwrap_or(0)
    }
}
