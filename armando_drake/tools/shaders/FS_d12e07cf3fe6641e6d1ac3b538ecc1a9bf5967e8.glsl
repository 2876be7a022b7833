#version 150
// armando-drake: the fragment shader of VTK's FXAA pass (the one Drake's RenderEngineVtk
// runs on every colour frame), replaced by a copy of its input. Mesa reads it from
// MESA_SHADER_READ_PATH when VTK compiles a shader whose source has this file's hash
// (armando_drake/sensors/antialiasing.py says why and when; armando_drake/tools/mesa.py
// points Mesa here).
out vec4 fragOutput0;
in vec2 texCoord;
uniform sampler2D Input;
uniform vec2 InvTexSize;
uniform float RelativeContrastThreshold;
uniform float HardContrastThreshold;
uniform float SubpixelBlendLimit;
uniform float SubpixelContrastThreshold;
uniform int EndpointSearchIterations;
void main()
{
  fragOutput0 = texelFetch(Input, ivec2(texCoord * vec2(textureSize(Input, 0))), 0);
}
