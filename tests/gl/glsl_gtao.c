/* glsl_gtao.c: GTAO as XeGTAO, re-typed in GLSL 4.50 from GameTechDev/XeGTAO
 * Source/Rendering/Shaders/XeGTAO.hlsli (version 1.30, the e7698f8 text docs/ao/gtao.md follows):
 * XeGTAO_PrefilterDepths16x16 + XeGTAO_DepthMIPFilter (one fragment pass per MIP level),
 * XeGTAO_MainPass with XeGTAO_CalculateEdges / PackEdges / CalculateNormal / FastSqrt / FastACos, the
 * noise of vaGTAO.hlsl SpatioTemporalNoise with XeGTAO.h HilbertIndex computed in the shader, and
 * XeGTAO_Denoise with UnpackEdges / AddSample, one pixel per fragment.
 *
 * Translated from HLSL compute to fragment passes (the math is per pixel):
 *   - D3D rows: every texture holds our rows as is (GLH_ROWS_AS_IS), so gl_FragCoord.xy - 0.5 is
 *     XeGTAO's pixCoord and texel (x, y) is our (x, y); no flip (XeGTAO is D3D, as our kernel).
 *   - GatherRed with g_samplerPointClamp -> texelFetch at the gathered texels, clamped to the level.
 *   - The prefilter's groupshared reduction -> one pass per MIP level reading the level above (the
 *     same 2x2 children in the same order: depth0..3 = (0,0), (1,0), (0,1), (1,1)).
 *   - SampleLevel(point-clamp, uv, mipLevel) -> the nearest level floor(mipLevel + 0.5) (at most 4)
 *     and texel floor(uv * size), clamped (docs/ao/gtao.md, MainPass step 7); the five levels are
 *     five textures, because a pass may not sample the texture it renders into.
 *   - round -> roundEven; frac -> fract; saturate -> clamp(.., 0, 1); lerp -> mix; asint/asfloat ->
 *     floatBitsToInt / intBitsToFloat.
 *   - The edges are stored as the 8-bit integer (L<<6 | R<<4 | T<<2 | B) in a float: XeGTAO stores
 *     k/255 in R8_UNORM and UnpackEdges reads uint(v * 255.5) = k.
 * Where our kernel documents a difference from XeGTAO (docs/ao/gtao.md, "Differences"), the port
 * follows ours: the FP32 path without 8-bit packing (difference 1: the working term is
 * min(visibility, 1.5), the last denoise pass does not multiply by 1.5), our background (depth not
 * > 0, uploaded as 0) is 65504 in MIP 0 and visibility 1 (difference 5), a degenerate normal gives
 * visibility 1 (6), the output is clamped to [0, 1] (7), the params are runtime constants (8),
 * normals from depth are computed in the main pass from MIP 0 (XeGTAO's
 * XE_GTAO_GENERATE_NORMALS_INPLACE form of XeGTAO_ComputeViewspaceNormal). Not ported: the
 * orthographic extension and gpu_packing (glsl_gtao_build refuses them). */
#include "gl/glsl_ports.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE

/* ---- PrefilterDepths: MIP 0 (XeGTAO_ClampDepth; our background -> 65504) ---- */
static const char *const fs_mip0 =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D srcDepth;\n"
    "layout(location=0) out vec4 outDepth;\n"
    "float XeGTAO_ClampDepth(float depth) { return clamp(depth, 0.0, 65504.0); }\n"
    "void main() {\n"
    "  float d = texelFetch(srcDepth, ivec2(gl_FragCoord.xy), 0).x;\n"
    "  /* our background (depth not > 0; non-finite uploaded as 0) is what an infinite-far reversed-Z\n"
    "     buffer gives XeGTAO: the clamp's 65504 (docs/ao/gtao.md, PrefilterDepths) */\n"
    "  outDepth = vec4(d > 0.0 ? XeGTAO_ClampDepth(d) : 65504.0);\n"
    "}\n";

/* ---- PrefilterDepths: MIP l from MIP l-1 (XeGTAO_DepthMIPFilter) ---- */
static const char *const fs_mipn =
    "#version 450\n"
    "uniform float EffectRadius; uniform float EffectFalloffRange; uniform float RadiusMultiplier;\n"
    "layout(binding=0) uniform sampler2D srcLevel;\n"
    "layout(location=0) out vec4 outDepth;\n"
    "float XeGTAO_DepthMIPFilter(float depth0, float depth1, float depth2, float depth3) {\n"
    "  float maxDepth = max(max(depth0, depth1), max(depth2, depth3));\n"
    "  float depthRangeScaleFactor = 0.75; // found empirically :)\n"
    "  float effectRadius = depthRangeScaleFactor * EffectRadius * RadiusMultiplier;\n"
    "  float falloffRange = EffectFalloffRange * effectRadius;\n"
    "  float falloffFrom = effectRadius * (1.0 - EffectFalloffRange);\n"
    "  float falloffMul = -1.0 / (falloffRange);\n"
    "  float falloffAdd = falloffFrom / (falloffRange) + 1.0;\n"
    "  float weight0 = clamp((maxDepth - depth0) * falloffMul + falloffAdd, 0.0, 1.0);\n"
    "  float weight1 = clamp((maxDepth - depth1) * falloffMul + falloffAdd, 0.0, 1.0);\n"
    "  float weight2 = clamp((maxDepth - depth2) * falloffMul + falloffAdd, 0.0, 1.0);\n"
    "  float weight3 = clamp((maxDepth - depth3) * falloffMul + falloffAdd, 0.0, 1.0);\n"
    "  float weightSum = weight0 + weight1 + weight2 + weight3;\n"
    "  return (weight0 * depth0 + weight1 * depth1 + weight2 * depth2 + weight3 * depth3) / weightSum;\n"
    "}\n"
    "void main() {\n"
    "  ivec2 baseCoord = ivec2(gl_FragCoord.xy), pixCoord = baseCoord * 2, last = textureSize(srcLevel, 0) - 1;\n"
    "  float depth0 = texelFetch(srcLevel, min(pixCoord + ivec2(0, 0), last), 0).x;\n"
    "  float depth1 = texelFetch(srcLevel, min(pixCoord + ivec2(1, 0), last), 0).x;\n"
    "  float depth2 = texelFetch(srcLevel, min(pixCoord + ivec2(0, 1), last), 0).x;\n"
    "  float depth3 = texelFetch(srcLevel, min(pixCoord + ivec2(1, 1), last), 0).x;\n"
    "  outDepth = vec4(XeGTAO_DepthMIPFilter(depth0, depth1, depth2, depth3));\n"
    "}\n";

/* ---- MainPass: out.r = the working term, out.g = the packed edges (integer 0..255) ---- */
static const char *const fs_main =
    "#version 450\n"
    "#define XE_GTAO_PI (3.1415926535897932384626433832795)\n"
    "#define XE_GTAO_PI_HALF (1.5707963267948966192313216916398)\n"
    "#define XE_GTAO_DEPTH_MIP_LEVELS 5.0\n"
    "#define XE_GTAO_OCCLUSION_TERM_SCALE 1.5\n"
    "uniform vec2 ViewportPixelSize; uniform vec2 NDCToViewMul; uniform vec2 NDCToViewAdd;\n"
    "uniform vec2 NDCToViewMul_x_PixelSize; uniform float EffectRadius; uniform float EffectFalloffRange;\n"
    "uniform float RadiusMultiplier; uniform float FinalValuePower; uniform float SampleDistributionPower;\n"
    "uniform float ThinOccluderCompensation; uniform float DepthMIPSamplingOffset; uniform int NoiseIndex;\n"
    "layout(binding=0) uniform sampler2D srcDepth;  /* our depth: background when not > 0 */\n"
    "layout(binding=1) uniform sampler2D depthMIP0; layout(binding=2) uniform sampler2D depthMIP1;\n"
    "layout(binding=3) uniform sampler2D depthMIP2; layout(binding=4) uniform sampler2D depthMIP3;\n"
    "layout(binding=5) uniform sampler2D depthMIP4; layout(binding=6) uniform sampler2D srcNormal;\n"
    "layout(location=0) out vec4 outWorking;\n"
    "vec3 XeGTAO_ComputeViewspacePosition(vec2 screenPos, float viewspaceDepth) {\n"
    "  vec3 ret; ret.xy = (NDCToViewMul * screenPos.xy + NDCToViewAdd) * viewspaceDepth; ret.z = viewspaceDepth;\n"
    "  return ret; }\n"
    "vec4 XeGTAO_CalculateEdges(float centerZ, float leftZ, float rightZ, float topZ, float bottomZ) {\n"
    "  vec4 edgesLRTB = vec4(leftZ, rightZ, topZ, bottomZ) - centerZ;\n"
    "  float slopeLR = (edgesLRTB.y - edgesLRTB.x) * 0.5;\n"
    "  float slopeTB = (edgesLRTB.w - edgesLRTB.z) * 0.5;\n"
    "  vec4 edgesLRTBSlopeAdjusted = edgesLRTB + vec4(slopeLR, -slopeLR, slopeTB, -slopeTB);\n"
    "  edgesLRTB = min(abs(edgesLRTB), abs(edgesLRTBSlopeAdjusted));\n"
    "  return vec4(clamp((1.25 - edgesLRTB / (centerZ * 0.011)), 0.0, 1.0)); }\n"
    "float XeGTAO_PackEdges(vec4 edgesLRTB) {\n"
    "  edgesLRTB = roundEven(clamp(edgesLRTB, 0.0, 1.0) * 2.9);\n"
    "  return dot(edgesLRTB, vec4(64.0, 16.0, 4.0, 1.0)); /* x 1/255 in R8_UNORM */ }\n"
    "vec3 XeGTAO_CalculateNormal(vec4 edgesLRTB, vec3 pixCenterPos, vec3 pixLPos, vec3 pixRPos, vec3 pixTPos, vec3 pixBPos) {\n"
    "  vec4 acceptedNormals = clamp(vec4(edgesLRTB.x*edgesLRTB.z, edgesLRTB.z*edgesLRTB.y, edgesLRTB.y*edgesLRTB.w, edgesLRTB.w*edgesLRTB.x) + 0.01, 0.0, 1.0);\n"
    "  pixLPos = normalize(pixLPos - pixCenterPos); pixRPos = normalize(pixRPos - pixCenterPos);\n"
    "  pixTPos = normalize(pixTPos - pixCenterPos); pixBPos = normalize(pixBPos - pixCenterPos);\n"
    "  vec3 pixelNormal = acceptedNormals.x * cross(pixLPos, pixTPos) + acceptedNormals.y * cross(pixTPos, pixRPos)\n"
    "                   + acceptedNormals.z * cross(pixRPos, pixBPos) + acceptedNormals.w * cross(pixBPos, pixLPos);\n"
    "  return pixelNormal; /* normalised by the caller after our degenerate-normal test */ }\n"
    "float XeGTAO_FastSqrt(float x) { return intBitsToFloat(0x1fbd1df5 + (floatBitsToInt(x) >> 1)); }\n"
    "float XeGTAO_FastACos(float inX) {\n"
    "  float PI = 3.141593; float HALF_PI = 1.570796;\n"
    "  float x = abs(inX); float res = -0.156583 * x + HALF_PI; res *= XeGTAO_FastSqrt(1.0 - x);\n"
    "  return (inX >= 0.0) ? res : PI - res; }\n"
    /* XeGTAO.h HilbertIndex (level 6), vaGTAO.hlsl SpatioTemporalNoise */
    "uint HilbertIndex(uint posX, uint posY) {\n"
    "  uint index = 0u;\n"
    "  for (uint curLevel = 64u / 2u; curLevel > 0u; curLevel /= 2u) {\n"
    "    uint regionX = (posX & curLevel) > 0u ? 1u : 0u; uint regionY = (posY & curLevel) > 0u ? 1u : 0u;\n"
    "    index += curLevel * curLevel * ((3u * regionX) ^ regionY);\n"
    "    if (regionY == 0u) { if (regionX == 1u) { posX = uint((64 - 1)) - posX; posY = uint((64 - 1)) - posY; }\n"
    "      uint temp = posX; posX = posY; posY = temp; } }\n"
    "  return index; }\n"
    "vec2 SpatioTemporalNoise(uvec2 pixCoord, uint temporalIndex) {\n"
    "  uint index = HilbertIndex(pixCoord.x % 64u, pixCoord.y % 64u);\n"
    "  index += 288u * (temporalIndex % 64u); // why 288? tried out a few and that's the best so far\n"
    "  precise vec2 r2 = 0.5 + float(index) * vec2(0.75487766624669276005, 0.5698402909980532659114);\n"
    "  return fract(r2); }\n"
    /* SampleLevel(g_samplerPointClamp, uv, mipLevel): nearest level, texel floor(uv * size), clamped */
    "float FetchLevel(sampler2D t, vec2 uv) { ivec2 size = textureSize(t, 0);\n"
    "  return texelFetch(t, clamp(ivec2(floor(uv * vec2(size))), ivec2(0), size - 1), 0).x; }\n"
    "float SampleLevelPoint(vec2 uv, float mipLevel) { int l = min(int(floor(mipLevel + 0.5)), 4);\n"
    "  if (l == 0) return FetchLevel(depthMIP0, uv); if (l == 1) return FetchLevel(depthMIP1, uv);\n"
    "  if (l == 2) return FetchLevel(depthMIP2, uv); if (l == 3) return FetchLevel(depthMIP3, uv);\n"
    "  return FetchLevel(depthMIP4, uv); }\n"
    "float Z0(ivec2 p) { return texelFetch(depthMIP0, clamp(p, ivec2(0), textureSize(depthMIP0, 0) - 1), 0).x; }\n"
    "void main() {\n"
    "  uvec2 pixCoord = uvec2(gl_FragCoord.xy);\n"
    "  float sliceCount = SLICE_COUNT; float stepsPerSlice = STEPS_PER_SLICE;\n"
    "  vec2 normalizedScreenPos = (vec2(pixCoord) + 0.5) * ViewportPixelSize;\n"
    "  ivec2 pc = ivec2(pixCoord);\n"
    "  /* valuesUL / valuesBR = GatherRed at pixCoord * ViewportPixelSize, offsets (0,0) and (1,1) */\n"
    "  float viewspaceZ = Z0(pc);\n"
    "  float pixLZ = Z0(pc + ivec2(-1, 0)); float pixTZ = Z0(pc + ivec2(0, -1));\n"
    "  float pixRZ = Z0(pc + ivec2(1, 0)); float pixBZ = Z0(pc + ivec2(0, 1));\n"
    "  vec4 edgesLRTB = XeGTAO_CalculateEdges(viewspaceZ, pixLZ, pixRZ, pixTZ, pixBZ);\n"
    "  float packedEdges = XeGTAO_PackEdges(edgesLRTB);\n"
    "  /* our background: visibility 1 (docs/ao/gtao.md, difference 5) */\n"
    "  if (!(texelFetch(srcDepth, pc, 0).x > 0.0)) { outWorking = vec4(1.0, packedEdges, 0.0, 0.0); return; }\n"
    "  vec3 viewspaceNormal;\n"
    "#if NORMALS_GBUFFER\n"
    "  viewspaceNormal = texelFetch(srcNormal, pc, 0).xyz * vec3(1.0, 1.0, -1.0); /* ours -> XeGTAO's +Z forward */\n"
    "#else\n"
    "  vec3 CENTER = XeGTAO_ComputeViewspacePosition(normalizedScreenPos, viewspaceZ);\n"
    "  vec3 LEFT   = XeGTAO_ComputeViewspacePosition(normalizedScreenPos + vec2(-1,  0) * ViewportPixelSize, pixLZ);\n"
    "  vec3 RIGHT  = XeGTAO_ComputeViewspacePosition(normalizedScreenPos + vec2( 1,  0) * ViewportPixelSize, pixRZ);\n"
    "  vec3 TOP    = XeGTAO_ComputeViewspacePosition(normalizedScreenPos + vec2( 0, -1) * ViewportPixelSize, pixTZ);\n"
    "  vec3 BOTTOM = XeGTAO_ComputeViewspacePosition(normalizedScreenPos + vec2( 0,  1) * ViewportPixelSize, pixBZ);\n"
    "  viewspaceNormal = XeGTAO_CalculateNormal(edgesLRTB, CENTER, LEFT, RIGHT, TOP, BOTTOM);\n"
    "#endif\n"
    "  /* a zero or non-finite normal: visibility 1 (docs/ao/gtao.md, difference 6); LoadNormal normalises */\n"
    "  float nl2 = dot(viewspaceNormal, viewspaceNormal);\n"
    "  if (!(nl2 > 0.0) || isinf(nl2)) { outWorking = vec4(1.0, packedEdges, 0.0, 0.0); return; }\n"
    "  viewspaceNormal = normalize(viewspaceNormal);\n"
    "  viewspaceZ *= 0.99999; // this is good for FP32 depth buffer\n"
    "  vec3 pixCenterPos = XeGTAO_ComputeViewspacePosition(normalizedScreenPos, viewspaceZ);\n"
    "  vec3 viewVec = normalize(-pixCenterPos);\n"
    "  float effectRadius = EffectRadius * RadiusMultiplier;\n"
    "  float sampleDistributionPower = SampleDistributionPower;\n"
    "  float thinOccluderCompensation = ThinOccluderCompensation;\n"
    "  float falloffRange = EffectFalloffRange * effectRadius;\n"
    "  float falloffFrom = effectRadius * (1.0 - EffectFalloffRange);\n"
    "  float falloffMul = -1.0 / (falloffRange);\n"
    "  float falloffAdd = falloffFrom / (falloffRange) + 1.0;\n"
    "  float visibility = 0.0;\n"
    "  {\n"
    "    vec2 localNoise = SpatioTemporalNoise(pixCoord, uint(NoiseIndex));\n"
    "    float noiseSlice = localNoise.x; float noiseSample = localNoise.y;\n"
    "    float pixelTooCloseThreshold = 1.3;\n"
    "    vec2 pixelDirRBViewspaceSizeAtCenterZ = vec2(viewspaceZ) * NDCToViewMul_x_PixelSize;\n"
    "    float screenspaceRadius = effectRadius / pixelDirRBViewspaceSizeAtCenterZ.x;\n"
    "    visibility += clamp((10.0 - screenspaceRadius) / 100.0, 0.0, 1.0) * 0.5;\n"
    "    float minS = pixelTooCloseThreshold / screenspaceRadius;\n"
    "    for (float slice = 0.0; slice < sliceCount; slice++) {\n"
    "      float sliceK = (slice + noiseSlice) / sliceCount;\n"
    "      float phi = sliceK * XE_GTAO_PI;\n"
    "      float cosPhi = cos(phi); float sinPhi = sin(phi);\n"
    "      vec2 omega = vec2(cosPhi, -sinPhi);\n"
    "      omega *= screenspaceRadius;\n"
    "      vec3 directionVec = vec3(cosPhi, sinPhi, 0.0);\n"
    "      vec3 orthoDirectionVec = directionVec - (dot(directionVec, viewVec) * viewVec);\n"
    "      vec3 axisVec = normalize(cross(orthoDirectionVec, viewVec));\n"
    "      vec3 projectedNormalVec = viewspaceNormal - axisVec * dot(viewspaceNormal, axisVec);\n"
    "      float signNorm = sign(dot(orthoDirectionVec, projectedNormalVec));\n"
    "      float projectedNormalVecLength = length(projectedNormalVec);\n"
    "      float cosNorm = clamp(dot(projectedNormalVec, viewVec) / projectedNormalVecLength, 0.0, 1.0);\n"
    "      float n = signNorm * XeGTAO_FastACos(cosNorm);\n"
    "      float lowHorizonCos0 = cos(n + XE_GTAO_PI_HALF);\n"
    "      float lowHorizonCos1 = cos(n - XE_GTAO_PI_HALF);\n"
    "      float horizonCos0 = lowHorizonCos0; float horizonCos1 = lowHorizonCos1;\n"
    "      for (float step = 0.0; step < stepsPerSlice; step++) {\n"
    "        float stepBaseNoise = float(slice + step * stepsPerSlice) * 0.6180339887498948482;\n"
    "        float stepNoise = fract(noiseSample + stepBaseNoise);\n"
    "        float s = (step + stepNoise) / (stepsPerSlice);\n"
    "        s = pow(s, sampleDistributionPower);\n"
    "        s += minS;\n"
    "        vec2 sampleOffset = s * omega;\n"
    "        float sampleOffsetLength = length(sampleOffset);\n"
    "        float mipLevel = clamp(log2(sampleOffsetLength) - DepthMIPSamplingOffset, 0.0, XE_GTAO_DEPTH_MIP_LEVELS);\n"
    "        sampleOffset = roundEven(sampleOffset) * ViewportPixelSize;\n"
    "        vec2 sampleScreenPos0 = normalizedScreenPos + sampleOffset;\n"
    "        float SZ0 = SampleLevelPoint(sampleScreenPos0, mipLevel);\n"
    "        vec3 samplePos0 = XeGTAO_ComputeViewspacePosition(sampleScreenPos0, SZ0);\n"
    "        vec2 sampleScreenPos1 = normalizedScreenPos - sampleOffset;\n"
    "        float SZ1 = SampleLevelPoint(sampleScreenPos1, mipLevel);\n"
    "        vec3 samplePos1 = XeGTAO_ComputeViewspacePosition(sampleScreenPos1, SZ1);\n"
    "        vec3 sampleDelta0 = (samplePos0 - pixCenterPos);\n"
    "        vec3 sampleDelta1 = (samplePos1 - pixCenterPos);\n"
    "        float sampleDist0 = length(sampleDelta0);\n"
    "        float sampleDist1 = length(sampleDelta1);\n"
    "        vec3 sampleHorizonVec0 = (sampleDelta0 / sampleDist0);\n"
    "        vec3 sampleHorizonVec1 = (sampleDelta1 / sampleDist1);\n"
    "        float falloffBase0 = length(vec3(sampleDelta0.x, sampleDelta0.y, sampleDelta0.z * (1.0 + thinOccluderCompensation)));\n"
    "        float falloffBase1 = length(vec3(sampleDelta1.x, sampleDelta1.y, sampleDelta1.z * (1.0 + thinOccluderCompensation)));\n"
    "        float weight0 = clamp(falloffBase0 * falloffMul + falloffAdd, 0.0, 1.0);\n"
    "        float weight1 = clamp(falloffBase1 * falloffMul + falloffAdd, 0.0, 1.0);\n"
    "        float shc0 = dot(sampleHorizonVec0, viewVec);\n"
    "        float shc1 = dot(sampleHorizonVec1, viewVec);\n"
    "        shc0 = mix(lowHorizonCos0, shc0, weight0);\n"
    "        shc1 = mix(lowHorizonCos1, shc1, weight1);\n"
    "        horizonCos0 = max(horizonCos0, shc0);\n"
    "        horizonCos1 = max(horizonCos1, shc1);\n"
    "      }\n"
    "      projectedNormalVecLength = mix(projectedNormalVecLength, 1.0, 0.05);\n"
    "      float h0 = -XeGTAO_FastACos(horizonCos1);\n"
    "      float h1 = XeGTAO_FastACos(horizonCos0);\n"
    "      float iarc0 = (cosNorm + 2.0 * h0 * sin(n) - cos(2.0 * h0 - n)) / 4.0;\n"
    "      float iarc1 = (cosNorm + 2.0 * h1 * sin(n) - cos(2.0 * h1 - n)) / 4.0;\n"
    "      float localVisibility = projectedNormalVecLength * (iarc0 + iarc1);\n"
    "      visibility += localVisibility;\n"
    "    }\n"
    "    visibility /= sliceCount;\n"
    "    visibility = pow(visibility, FinalValuePower);\n"
    "    visibility = max(0.03, visibility);\n"
    "  }\n"
    "  /* XeGTAO_OutputWorkingTerm stores saturate(v / 1.5) in 8 bits; FP32 (difference 1): min(v, 1.5) */\n"
    "  outWorking = vec4(min(visibility, XE_GTAO_OCCLUSION_TERM_SCALE), packedEdges, 0.0, 0.0);\n"
    "}\n";

/* ---- Denoise: one pixel of XeGTAO_Denoise (XeGTAO runs two per thread from GatherRed quads) ----
 * unit 0: the AO term (r), unit 1: the main pass (g = packed edges), unit 2: our depth (last pass:
 * background -> 1). Origin: the window's corner in the full buffer (the last pass renders it). */
static const char *const fs_denoise =
    "#version 450\n"
    "uniform float DenoiseBlurBeta; uniform ivec2 Origin;\n"
    "layout(binding=0) uniform sampler2D sourceAOTerm; layout(binding=1) uniform sampler2D sourceEdges;\n"
    "layout(binding=2) uniform sampler2D srcDepth;\n"
    "layout(location=0) out vec4 outputTexture;\n"
    "vec4 XeGTAO_UnpackEdges(float _packedVal) {\n"
    "  uint packedVal = uint(_packedVal); /* the stored integer (uint(k/255 * 255.5) = k) */\n"
    "  vec4 edgesLRTB;\n"
    "  edgesLRTB.x = float((packedVal >> 6) & 0x03u) / 3.0;\n"
    "  edgesLRTB.y = float((packedVal >> 4) & 0x03u) / 3.0;\n"
    "  edgesLRTB.z = float((packedVal >> 2) & 0x03u) / 3.0;\n"
    "  edgesLRTB.w = float((packedVal >> 0) & 0x03u) / 3.0;\n"
    "  return clamp(edgesLRTB, 0.0, 1.0); }\n"
    "void XeGTAO_AddSample(float ssaoValue, float edgeValue, inout float sum, inout float sumWeight) {\n"
    "  float weight = edgeValue; sum += (weight * ssaoValue); sumWeight += weight; }\n"
    "ivec2 C(ivec2 p) { return clamp(p, ivec2(0), textureSize(sourceAOTerm, 0) - 1); }\n"
    "float V(ivec2 p) { return texelFetch(sourceAOTerm, C(p), 0).x; }\n"
    "float E(ivec2 p) { return texelFetch(sourceEdges, C(p), 0).y; }\n"
    "void main() {\n"
    "  ivec2 pixCoord = ivec2(gl_FragCoord.xy) + Origin;\n"
    "#if FINAL_APPLY\n"
    "  if (!(texelFetch(srcDepth, pixCoord, 0).x > 0.0)) { outputTexture = vec4(1.0); return; } /* our background */\n"
    "  float blurAmount = DenoiseBlurBeta;\n"
    "#else\n"
    "  float blurAmount = DenoiseBlurBeta / 5.0;\n"
    "#endif\n"
    "  float diagWeight = 0.85 * 0.5;\n"
    "  vec4 edgesL_LRTB = XeGTAO_UnpackEdges(E(pixCoord + ivec2(-1, 0)));\n"
    "  vec4 edgesT_LRTB = XeGTAO_UnpackEdges(E(pixCoord + ivec2(0, -1)));\n"
    "  vec4 edgesR_LRTB = XeGTAO_UnpackEdges(E(pixCoord + ivec2(1, 0)));\n"
    "  vec4 edgesB_LRTB = XeGTAO_UnpackEdges(E(pixCoord + ivec2(0, 1)));\n"
    "  vec4 edgesC_LRTB = XeGTAO_UnpackEdges(E(pixCoord));\n"
    "  edgesC_LRTB *= vec4(edgesL_LRTB.y, edgesR_LRTB.x, edgesT_LRTB.w, edgesB_LRTB.z);\n"
    "  float leak_threshold = 2.5; float leak_strength = 0.5;\n"
    "  float edginess = (clamp(4.0 - leak_threshold - dot(edgesC_LRTB, vec4(1.0)), 0.0, 1.0) / (4.0 - leak_threshold)) * leak_strength;\n"
    "  edgesC_LRTB = clamp(edgesC_LRTB + edginess, 0.0, 1.0);\n"
    "  float weightTL = diagWeight * (edgesC_LRTB.x * edgesL_LRTB.z + edgesC_LRTB.z * edgesT_LRTB.x);\n"
    "  float weightTR = diagWeight * (edgesC_LRTB.z * edgesT_LRTB.y + edgesC_LRTB.y * edgesR_LRTB.z);\n"
    "  float weightBL = diagWeight * (edgesC_LRTB.w * edgesB_LRTB.x + edgesC_LRTB.x * edgesL_LRTB.w);\n"
    "  float weightBR = diagWeight * (edgesC_LRTB.y * edgesR_LRTB.w + edgesC_LRTB.w * edgesB_LRTB.y);\n"
    "  float ssaoValue = V(pixCoord);\n"
    "  float ssaoValueL = V(pixCoord + ivec2(-1, 0)); float ssaoValueT = V(pixCoord + ivec2(0, -1));\n"
    "  float ssaoValueR = V(pixCoord + ivec2(1, 0)); float ssaoValueB = V(pixCoord + ivec2(0, 1));\n"
    "  float ssaoValueTL = V(pixCoord + ivec2(-1, -1)); float ssaoValueBR = V(pixCoord + ivec2(1, 1));\n"
    "  float ssaoValueTR = V(pixCoord + ivec2(1, -1)); float ssaoValueBL = V(pixCoord + ivec2(-1, 1));\n"
    "  float sumWeight = blurAmount;\n"
    "  float sum = ssaoValue * sumWeight;\n"
    "  XeGTAO_AddSample(ssaoValueL, edgesC_LRTB.x, sum, sumWeight);\n"
    "  XeGTAO_AddSample(ssaoValueR, edgesC_LRTB.y, sum, sumWeight);\n"
    "  XeGTAO_AddSample(ssaoValueT, edgesC_LRTB.z, sum, sumWeight);\n"
    "  XeGTAO_AddSample(ssaoValueB, edgesC_LRTB.w, sum, sumWeight);\n"
    "  XeGTAO_AddSample(ssaoValueTL, weightTL, sum, sumWeight);\n"
    "  XeGTAO_AddSample(ssaoValueTR, weightTR, sum, sumWeight);\n"
    "  XeGTAO_AddSample(ssaoValueBL, weightBL, sum, sumWeight);\n"
    "  XeGTAO_AddSample(ssaoValueBR, weightBR, sum, sumWeight);\n"
    "  float aoTerm = sum / sumWeight;\n"
    "#if FINAL_APPLY\n"
    "  aoTerm = clamp(aoTerm, 0.0, 1.0); /* XeGTAO: * 1.5 into R8_UINT; FP32 (differences 1, 7): clamp */\n"
    "#endif\n"
    "  outputTexture = vec4(aoTerm);\n"
    "}\n";

/* ---- Without the denoiser: the main pass's term over the window, clamped (our out_raw) ---- */
static const char *const fs_store =
    "#version 450\n"
    "uniform ivec2 Origin;\n"
    "layout(binding=0) uniform sampler2D sourceAOTerm;\n"
    "layout(location=0) out vec4 o;\n"
    "void main() { o = vec4(clamp(texelFetch(sourceAOTerm, ivec2(gl_FragCoord.xy) + Origin, 0).x, 0.0, 1.0)); }\n";

static GLuint own_tex(glh *g, glh_run *r, int w, int h, GLenum fmt, int comps, const float *data)
{
    return glh_run_own_texture(r, glh_texture(g, w, h, 1, fmt, comps, data, GLH_ROWS_AS_IS, GL_NEAREST,
                                              GL_CLAMP_TO_EDGE));
}

int glsl_gtao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_gtao_params *p, glh_run *r)
{
    memset(r, 0, sizeof *r);
    if (ao_input_validate(ctx, in) != OBS_STATUS_OK || ao_gtao_params_validate(ctx, p) != OBS_STATUS_OK) {
        printf("  gtao port: %s\n", obs_context_last_error(ctx));
        return 0;
    }
    const ao_gtao_constants k = ao_gtao_constants_from_params(p, in);
    if (k.orthographic || k.gpu_packing) {
        printf("  gtao port: the orthographic extension and gpu_packing are not ported\n");
        return 0;
    }
    const int W = in->width, H = in->height;
    /* our depth with non-finite values as 0: background is "not > 0" in the shaders */
    GLuint tdepth = glh_run_own_texture(r, glh_texture_from_image(g, in->depth, GLH_ROWS_AS_IS, 0.0f, GL_NEAREST,
                                                                   GL_CLAMP_TO_EDGE));
    GLuint tnorm = 0;
    if (k.normals_from_gbuffer) {
        float *n4 = malloc(sizeof(float) * 4 * (size_t)W * (size_t)H);
        if (!n4)
            return 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int c = 0; c < 4; c++)
                    n4[4 * ((size_t)y * W + x) + c] = c < 3 ? obs_image_f32_row(in->normal[c], y)[x] : 0.0f;
        tnorm = own_tex(g, r, W, H, GL_RGBA32F, 4, n4);
        free(n4);
    } else {
        tnorm = tdepth; /* unused (NORMALS_GBUFFER 0) */
    }
    /* MIP chain: five textures, max(1, size >> 1) per level */
    GLuint mip[AO_GTAO_DEPTH_MIP_LEVELS], mipfb[AO_GTAO_DEPTH_MIP_LEVELS];
    int mw[AO_GTAO_DEPTH_MIP_LEVELS], mh[AO_GTAO_DEPTH_MIP_LEVELS];
    for (int l = 0; l < AO_GTAO_DEPTH_MIP_LEVELS; l++) {
        mw[l] = l ? (mw[l - 1] > 1 ? mw[l - 1] >> 1 : 1) : W;
        mh[l] = l ? (mh[l - 1] > 1 ? mh[l - 1] >> 1 : 1) : H;
        mip[l] = own_tex(g, r, mw[l], mh[l], GL_R32F, 1, NULL);
        mipfb[l] = glh_run_own_fbo(r, glh_framebuffer(g, mip[l], 0));
    }
    GLuint tmain = own_tex(g, r, W, H, GL_RG32F, 2, NULL);
    GLuint fmain = glh_run_own_fbo(r, glh_framebuffer(g, tmain, 0));
    char pre[160];
    snprintf(pre, sizeof pre, "#define SLICE_COUNT %d.0\n#define STEPS_PER_SLICE %d.0\n#define NORMALS_GBUFFER %d\n",
             k.slice_count, k.steps_per_slice, k.normals_from_gbuffer);
    GLuint pm0 = glh_run_own_program(r, glh_program(g, fs_mip0, NULL));
    GLuint pmn = glh_run_own_program(r, glh_program(g, fs_mipn, NULL));
    GLuint pmain = glh_run_own_program(r, glh_program(g, fs_main, pre));
    if (!tdepth || !tnorm || !tmain || !fmain || !pm0 || !pmn || !pmain)
        return 0;
    for (int l = 0; l < AO_GTAO_DEPTH_MIP_LEVELS; l++)
        if (!mip[l] || !mipfb[l])
            return 0;
    /* uniforms: GTAOConstants from ao_gtao_constants_from_params (GTAOUpdateConstants) */
    glh_set1f(g, pmn, "EffectRadius", k.effect_radius);
    glh_set1f(g, pmn, "EffectFalloffRange", k.effect_falloff_range);
    glh_set1f(g, pmn, "RadiusMultiplier", k.radius_multiplier);
    glh_set2f(g, pmain, "ViewportPixelSize", k.viewport_pixel_size[0], k.viewport_pixel_size[1]);
    glh_set2f(g, pmain, "NDCToViewMul", k.ndc_to_view_mul[0], k.ndc_to_view_mul[1]);
    glh_set2f(g, pmain, "NDCToViewAdd", k.ndc_to_view_add[0], k.ndc_to_view_add[1]);
    glh_set2f(g, pmain, "NDCToViewMul_x_PixelSize", k.ndc_to_view_mul_x_pixel_size[0],
              k.ndc_to_view_mul_x_pixel_size[1]);
    glh_set1f(g, pmain, "EffectRadius", k.effect_radius);
    glh_set1f(g, pmain, "EffectFalloffRange", k.effect_falloff_range);
    glh_set1f(g, pmain, "RadiusMultiplier", k.radius_multiplier);
    glh_set1f(g, pmain, "FinalValuePower", k.final_value_power);
    glh_set1f(g, pmain, "SampleDistributionPower", k.sample_distribution_power);
    glh_set1f(g, pmain, "ThinOccluderCompensation", k.thin_occluder_compensation);
    glh_set1f(g, pmain, "DepthMIPSamplingOffset", k.depth_mip_sampling_offset);
    glh_set1i(g, pmain, "NoiseIndex", k.noise_index);

    static const char *const mip_names[] = {"gtao prefilter mip 0", "gtao prefilter mip 1", "gtao prefilter mip 2",
                                            "gtao prefilter mip 3", "gtao prefilter mip 4"};
    glh_run_add(r, mip_names[0], pm0, mipfb[0], W, H, 1, &tdepth);
    for (int l = 1; l < AO_GTAO_DEPTH_MIP_LEVELS; l++)
        glh_run_add(r, mip_names[l], pmn, mipfb[l], mw[l], mh[l], 1, &mip[l - 1]);
    const GLuint main_tex[7] = {tdepth, mip[0], mip[1], mip[2], mip[3], mip[4], tnorm};
    glh_run_add(r, "gtao main pass", pmain, fmain, W, H, 7, main_tex);
    r->nkernel = r->npass;

    const int passes = k.denoise_passes; /* 0: blur off; else max(1, DenoisePasses) */
    GLuint final_fb = 0;
    if (passes == 0) {
        GLuint ps = glh_run_own_program(r, glh_program(g, fs_store, NULL));
        GLuint to = own_tex(g, r, in->w, in->h, GL_R32F, 1, NULL);
        final_fb = glh_run_own_fbo(r, glh_framebuffer(g, to, 0));
        if (!ps || !to || !final_fb)
            return 0;
        glh_set2i(g, ps, "Origin", in->x0, in->y0);
        glh_run_add(r, "gtao output", ps, final_fb, in->w, in->h, 1, &tmain);
        r->nkernel = r->npass;
    } else {
        GLuint pmid = glh_run_own_program(r, glh_program(g, fs_denoise, "#define FINAL_APPLY 0\n"));
        GLuint plast = glh_run_own_program(r, glh_program(g, fs_denoise, "#define FINAL_APPLY 1\n"));
        if (!pmid || !plast)
            return 0;
        glh_set1f(g, pmid, "DenoiseBlurBeta", k.denoise_blur_beta);
        glh_set2i(g, pmid, "Origin", 0, 0);
        glh_set1f(g, plast, "DenoiseBlurBeta", k.denoise_blur_beta);
        glh_set2i(g, plast, "Origin", in->x0, in->y0);
        GLuint ping[2], pingfb[2];
        for (int i = 0; i < 2; i++) {
            ping[i] = own_tex(g, r, W, H, GL_R32F, 1, NULL);
            pingfb[i] = glh_run_own_fbo(r, glh_framebuffer(g, ping[i], 0));
            if (!ping[i] || !pingfb[i])
                return 0;
        }
        GLuint to = own_tex(g, r, in->w, in->h, GL_R32F, 1, NULL);
        final_fb = glh_run_own_fbo(r, glh_framebuffer(g, to, 0));
        if (!to || !final_fb)
            return 0;
        GLuint src = tmain; /* its .r is the working term */
        for (int i = 0; i < passes; i++) {
            const int last = i == passes - 1;
            const GLuint tex[3] = {src, tmain, tdepth};
            glh_run_add(r, last ? "gtao denoise (last)" : "gtao denoise", last ? plast : pmid,
                        last ? final_fb : pingfb[i & 1], last ? in->w : W, last ? in->h : H, 3, tex);
            src = ping[i & 1];
        }
    }
    r->out_fbo = final_fb;
    r->out_w = in->w;
    r->out_h = in->h;
    r->out_rows = GLH_ROWS_AS_IS;
    return 1;
}

#else
int glsl_gtao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_gtao_params *p, glh_run *r)
{
    (void)g, (void)ctx, (void)in, (void)p, (void)r;
    return 0;
}
#endif

/* ---- the benchmark's view: XeGTAO's defaults (High, 3 x 3, one sharp denoise pass) ---- */
static int port_build(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    const ao_gtao_params p = ao_gtao_params_default();
    return glsl_gtao_build(g, ctx, in, &p, r);
}

static obs_status port_kernel(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    ao_gtao_params p = ao_gtao_params_default();
    p.blur = 0;
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, in->w, in->h, out);
    return st != OBS_STATUS_OK ? st : ao_gtao_compute(ctx, pool, in, &p, out, NULL, NULL);
}

static obs_status port_full(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    const ao_gtao_params p = ao_gtao_params_default();
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, in->w, in->h, out);
    return st != OBS_STATUS_OK ? st : ao_gtao_compute(ctx, pool, in, &p, out, NULL, NULL);
}

/* ours_blur is NULL: XeGTAO_Denoise reads the main pass's packed edges as well as its term, so our
 * denoiser does not run alone on a visibility plane (ao_gtao_compute runs it after its main pass). */
const glsl_port glsl_port_gtao = {"gtao", "XeGTAO High (3 slices x 3 steps), 1 denoise pass", port_build, port_kernel,
                                  NULL, port_full};
