/*
 * Node types that are roles rather than kernels (sg_node_role): groups, their interface
 * nodes and reroutes are inlined away by flattening (flatten.c); Principled BSDF and
 * Material Output are sinks whose inputs are read (by the renderer, or as sockets to
 * evaluate) but which compute nothing here. Their socket tables still matter: they define the identifiers,
 * types and defaults that graphs may use (Blender 4.x vocabulary).
 */
#include "shadergraph/node_type.h"


const sg_node_type node_type_group = {
    .idname = "ShaderNodeGroup", .flags = SG_NODE_STRUCTURAL, .role = SG_ROLE_GROUP};
const sg_node_type node_type_group_input = {
    .idname = "NodeGroupInput", .flags = SG_NODE_STRUCTURAL, .role = SG_ROLE_GROUP_INPUT};
const sg_node_type node_type_group_output = {
    .idname = "NodeGroupOutput", .flags = SG_NODE_STRUCTURAL, .role = SG_ROLE_GROUP_OUTPUT};

static const sg_socket_def reroute_in[] = {{"Input", "Input", SG_SOCKET_COLOR, {0, 0, 0, 1}}};
static const sg_socket_def reroute_out[] = {{"Output", "Output", SG_SOCKET_COLOR, {0, 0, 0, 1}}};
const sg_node_type node_type_reroute = {
    .idname = "NodeReroute",
    .inputs = reroute_in, .n_inputs = 1,
    .outputs = reroute_out, .n_outputs = 1,
    .flags = SG_NODE_STRUCTURAL, .role = SG_ROLE_REROUTE};

/* Blender 4.3's Principled BSDF, in its socket order. */
static const sg_socket_def principled_in[] = {
    {"Base Color", "Base Color", SG_SOCKET_COLOR, {0.8f, 0.8f, 0.8f, 1.0f}},
    {"Metallic", "Metallic", SG_SOCKET_FLOAT, {0.0f}},
    {"Roughness", "Roughness", SG_SOCKET_FLOAT, {0.5f}},
    {"IOR", "IOR", SG_SOCKET_FLOAT, {1.5f}},
    {"Alpha", "Alpha", SG_SOCKET_FLOAT, {1.0f}},
    {"Normal", "Normal", SG_SOCKET_VECTOR, {0}, SG_IMPLICIT_NORMAL},
    {"Weight", "Weight", SG_SOCKET_FLOAT, {0.0f}},
    {"Diffuse Roughness", "Diffuse Roughness", SG_SOCKET_FLOAT, {0.0f}},
    {"Subsurface Weight", "Subsurface Weight", SG_SOCKET_FLOAT, {0.0f}},
    {"Subsurface Radius", "Subsurface Radius", SG_SOCKET_VECTOR, {1.0f, 0.2f, 0.1f}},
    {"Subsurface Scale", "Subsurface Scale", SG_SOCKET_FLOAT, {0.05f}},
    {"Subsurface IOR", "Subsurface IOR", SG_SOCKET_FLOAT, {1.4f}},
    {"Subsurface Anisotropy", "Subsurface Anisotropy", SG_SOCKET_FLOAT, {0.0f}},
    {"Specular IOR Level", "Specular IOR Level", SG_SOCKET_FLOAT, {0.5f}},
    {"Specular Tint", "Specular Tint", SG_SOCKET_COLOR, {1.0f, 1.0f, 1.0f, 1.0f}},
    {"Anisotropic", "Anisotropic", SG_SOCKET_FLOAT, {0.0f}},
    {"Anisotropic Rotation", "Anisotropic Rotation", SG_SOCKET_FLOAT, {0.0f}},
    {"Tangent", "Tangent", SG_SOCKET_VECTOR, {0}},
    {"Transmission Weight", "Transmission Weight", SG_SOCKET_FLOAT, {0.0f}},
    {"Coat Weight", "Coat Weight", SG_SOCKET_FLOAT, {0.0f}},
    {"Coat Roughness", "Coat Roughness", SG_SOCKET_FLOAT, {0.03f}},
    {"Coat IOR", "Coat IOR", SG_SOCKET_FLOAT, {1.5f}},
    {"Coat Tint", "Coat Tint", SG_SOCKET_COLOR, {1.0f, 1.0f, 1.0f, 1.0f}},
    {"Coat Normal", "Coat Normal", SG_SOCKET_VECTOR, {0}, SG_IMPLICIT_NORMAL},
    {"Sheen Weight", "Sheen Weight", SG_SOCKET_FLOAT, {0.0f}},
    {"Sheen Roughness", "Sheen Roughness", SG_SOCKET_FLOAT, {0.5f}},
    {"Sheen Tint", "Sheen Tint", SG_SOCKET_COLOR, {1.0f, 1.0f, 1.0f, 1.0f}},
    {"Emission Color", "Emission Color", SG_SOCKET_COLOR, {1.0f, 1.0f, 1.0f, 1.0f}},
    {"Emission Strength", "Emission Strength", SG_SOCKET_FLOAT, {0.0f}},
    {"Thin Film Thickness", "Thin Film Thickness", SG_SOCKET_FLOAT, {0.0f}},
    {"Thin Film IOR", "Thin Film IOR", SG_SOCKET_FLOAT, {1.33f}},
};
static const sg_socket_def principled_out[] = {{"BSDF", "BSDF", SG_SOCKET_SHADER, {0}}};
static const char *const principled_distributions[] = {"GGX", "MULTI_GGX", NULL};
static const char *const principled_subsurface[] = {"BURLEY", "RANDOM_WALK", "RANDOM_WALK_SKIN", NULL};
static const sg_prop_def principled_props[] = {
    {"distribution", SG_PROP_ENUM, principled_distributions, 1},
    {"subsurface_method", SG_PROP_ENUM, principled_subsurface, 1},
};
const sg_node_type node_type_bsdf_principled = {
    .idname = "ShaderNodeBsdfPrincipled",
    .inputs = principled_in, .n_inputs = SG_COUNT(principled_in),
    .outputs = principled_out, .n_outputs = 1,
    .props = principled_props, .n_props = SG_COUNT(principled_props),
    .flags = SG_NODE_SINK, .role = SG_ROLE_BSDF};

static const sg_socket_def output_in[] = {
    {"Surface", "Surface", SG_SOCKET_SHADER, {0}},
    {"Volume", "Volume", SG_SOCKET_SHADER, {0}},
    {"Displacement", "Displacement", SG_SOCKET_VECTOR, {0}},
    {"Thickness", "Thickness", SG_SOCKET_FLOAT, {0}},
};
static const char *const output_targets[] = {"ALL", "EEVEE", "CYCLES", NULL};
static const sg_prop_def output_props[] = {
    {"target", SG_PROP_ENUM, output_targets, 0},
    {"is_active_output", SG_PROP_BOOL, NULL, 1},
};
const sg_node_type node_type_output_material = {
    .idname = "ShaderNodeOutputMaterial",
    .inputs = output_in, .n_inputs = SG_COUNT(output_in),
    .props = output_props, .n_props = SG_COUNT(output_props),
    .flags = SG_NODE_SINK, .role = SG_ROLE_MATERIAL_OUTPUT};
