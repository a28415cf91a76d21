// What a GPU's texture unit returns for a bilinear lookup (the weights Cycles' GPU bakes get):
//   probe W H ADDRESS(wrap|clamp) MEMORY(array|pitch) COORDS OUT [random]
// The texture is W x H float4 texels holding (x mod 2, y mod 2, 0, 1), so a lookup's x and y
// are its two weights (or one less them); with "random", pseudo-random values in 0..1 (written
// to OUT.texels as W x H float4), which show the filter's arithmetic. COORDS: float32 pairs
// (u, v), normalised as Cycles passes them; OUT: float32 pairs, the lookup's first two channels.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>
#include <cuda_runtime.h>

#define CHECK(x) do { cudaError_t e = (x); if (e != cudaSuccess) { \
  fprintf(stderr, "%s: %s\n", #x, cudaGetErrorString(e)); exit(1); } } while (0)

__global__ void lookup(cudaTextureObject_t tex, const float2 *uv, float2 *out, int n) {
  int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) { float4 c = tex2D<float4>(tex, uv[i].x, uv[i].y); out[i] = make_float2(c.x, c.y); }
}

int main(int argc, char **argv) {
  if (argc != 7 && argc != 8) { fprintf(stderr, "usage: probe W H wrap|clamp array|pitch COORDS OUT [random]\n"); return 2; }
  bool random = argc == 8;
  int w = atoi(argv[1]), h = atoi(argv[2]);
  bool wrap = !strcmp(argv[3], "wrap"), pitch = !strcmp(argv[4], "pitch");
  FILE *f = fopen(argv[5], "rb"); if (!f) { perror(argv[5]); return 1; }
  fseek(f, 0, SEEK_END); long bytes = ftell(f); fseek(f, 0, SEEK_SET);
  int n = (int)(bytes / 8);
  std::vector<float2> uv(n), res(n);
  if (fread(uv.data(), 8, n, f) != (size_t)n) { fprintf(stderr, "short read\n"); return 1; }
  fclose(f);
  std::vector<float4> texels((size_t)w * h);
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) texels[(size_t)y * w + x] = make_float4(x & 1, y & 1, 0, 1);
  if (random) {
    unsigned s = 12345u;
    for (auto &t : texels) {
      float c[4];
      for (float &v : c) { s = s * 1664525u + 1013904223u; v = (s >> 8) * (1.0f / 16777216.0f); }
      t = make_float4(c[0], c[1], c[2], c[3]);
    }
    std::string name = std::string(argv[6]) + ".texels";
    FILE *tf = fopen(name.c_str(), "wb"); fwrite(texels.data(), 16, texels.size(), tf); fclose(tf);
  }
  cudaResourceDesc rd; memset(&rd, 0, sizeof rd);
  cudaChannelFormatDesc ch = cudaCreateChannelDesc<float4>();
  cudaArray_t arr = nullptr; void *lin = nullptr; size_t pitch_bytes = 0;
  if (pitch) {
    CHECK(cudaMallocPitch(&lin, &pitch_bytes, (size_t)w * sizeof(float4), h));
    CHECK(cudaMemcpy2D(lin, pitch_bytes, texels.data(), w * sizeof(float4), w * sizeof(float4), h,
                       cudaMemcpyHostToDevice));
    rd.resType = cudaResourceTypePitch2D; rd.res.pitch2D.devPtr = lin; rd.res.pitch2D.desc = ch;
    rd.res.pitch2D.width = w; rd.res.pitch2D.height = h; rd.res.pitch2D.pitchInBytes = pitch_bytes;
  } else {
    CHECK(cudaMallocArray(&arr, &ch, w, h));
    CHECK(cudaMemcpy2DToArray(arr, 0, 0, texels.data(), w * sizeof(float4), w * sizeof(float4), h,
                              cudaMemcpyHostToDevice));
    rd.resType = cudaResourceTypeArray; rd.res.array.array = arr;
  }
  cudaTextureDesc td; memset(&td, 0, sizeof td);
  td.addressMode[0] = td.addressMode[1] = wrap ? cudaAddressModeWrap : cudaAddressModeClamp;
  td.filterMode = cudaFilterModeLinear; td.readMode = cudaReadModeElementType;
  td.normalizedCoords = 1;
  cudaTextureObject_t tex; CHECK(cudaCreateTextureObject(&tex, &rd, &td, nullptr));
  float2 *duv, *dout;
  CHECK(cudaMalloc(&duv, n * sizeof(float2))); CHECK(cudaMalloc(&dout, n * sizeof(float2)));
  CHECK(cudaMemcpy(duv, uv.data(), n * sizeof(float2), cudaMemcpyHostToDevice));
  lookup<<<(n + 255) / 256, 256>>>(tex, duv, dout, n);
  CHECK(cudaGetLastError()); CHECK(cudaDeviceSynchronize());
  CHECK(cudaMemcpy(res.data(), dout, n * sizeof(float2), cudaMemcpyDeviceToHost));
  FILE *o = fopen(argv[6], "wb"); fwrite(res.data(), 8, n, o); fclose(o);
  cudaDeviceProp p; CHECK(cudaGetDeviceProperties(&p, 0));
  printf("probe: %s, %dx%d %s %s, %d lookups\n", p.name, w, h, argv[3], argv[4], n);
  return 0;
}
