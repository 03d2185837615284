// The correlation kernel, written once with OpenCV universal intrinsics (vx_ types of the
// widest width the translation unit is compiled for). Included by ncc_kernel_baseline.cc
// and ncc_kernel_avx2.cc inside a namespace of their own. Everything here has internal
// linkage and uses no standard-library templates, so the AVX2 copy never leaks into the
// portable code through the linker.
//
// Algorithm (Krotkov & Hebert sec. 3.2 and 3.4). For an output row y, column sums
//   col[i][k] = sum_{j=-my..my} R(x_i, y + j*dy) * T(x_i + d_min + k, y + j*dy)
// are kept for every grid column x_i and disparity index k (k contiguous, so the updates
// vectorise across disparities), and updated recursively from row to row: add the products
// of the row entering the window, subtract those of the row leaving it, both at once with
// one int16 multiply-add (v_dotprod) on interleaved pairs of target rows. The window sum is
// then the paper's recursion over grid columns, S(x+dx) = S(x) + S_y(x+(mx+1)dx) - S_y(x-mx*dx).
// With the window means and variances (also running sums) the correlation
//   C = (S - Sum_r Sum_t / n) / (n sigma_r sigma_t)
// is evaluated for every k in float for the search, and exactly (double, from the integer
// sums) at the best disparity and its two neighbours.

namespace {

constexpr int kLanes = cv::v_int32::nlanes;
constexpr float kNegInf = -__builtin_inff();
alignas(64) constexpr std::int32_t kIota[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};

inline int MinInt(int a, int b) { return a < b ? a : b; }
inline int MaxInt(int a, int b) { return a > b ? a : b; }

struct Workspace {
  std::int32_t* col;      // num_cols x Dp column sums of products
  std::int32_t* sum;      // Dp window sums of products, current grid column
  float* curve;           // Dp + 2 (sentinels at both ends): float correlation curve
  std::int16_t* pairs;    // 2 * Wp interleaved target rows (zero padded)
  std::int64_t* t_col1;   // width: vertical sums of T at each column
  std::int64_t* t_col2;   // width: vertical sums of T^2
  std::int64_t* r_col1;   // width
  std::int64_t* r_col2;   // width
  // Window statistics. Sums and V = n*sum(v^2) - sum(v)^2 are integers held exactly in double.
  double* t_sum;          // Wp: window sum of T at padded column p (0 outside)
  double* t_var;          // Wp: V of T (0 outside)
  double* t_inv;          // Wp: 1 / sqrt(V_t), 0 where V_t == 0
  float* t_u;             // Wp: t_sum * t_k (float)
  float* t_k;             // Wp: sqrt(n) * t_inv (float)
  double* r_sum;          // width
  double* r_var;          // width
  double* r_inv;          // width: 1 / sqrt(V_r), 0 where V_r == 0
  lunarnav::stereo::internal::PeakRecord* records;  // num_cols: the current output row
  std::int32_t* best_sums;  // 3 * num_cols: S at best-1, best, best+1 of the current row
};

inline std::size_t AlignUp(std::size_t bytes) { return (bytes + 63) / 64 * 64; }

struct Geometry {
  int dp;      // padded disparities
  int xa;      // leftmost target column represented in padded arrays (<= 0)
  int wp;      // padded width
  int n;       // pixels in the subsampled window
  int half_x;  // mx * dx, half window in pixels
};

inline Geometry MakeGeometry(const lunarnav::stereo::internal::KernelInput& in) {
  Geometry g;
  g.dp = lunarnav::stereo::internal::PaddedDisparities(in.num_disp);
  g.xa = MinInt(0, in.d_min);
  const int xb = MaxInt(in.width - 1, in.width - 1 + in.d_min + g.dp - 1);
  g.wp = xb - g.xa + 1;
  g.n = (2 * in.mx + 1) * (2 * in.my + 1);
  g.half_x = in.mx * in.step_x;
  return g;
}

// Carves the workspace; returns the bytes used (for KernelWorkspaceBytes with base == nullptr).
inline std::size_t LayoutWorkspace(const lunarnav::stereo::internal::KernelInput& in,
                                   const Geometry& g, unsigned char* base, Workspace* ws) {
  std::size_t offset = 0;
  auto take = [&](std::size_t bytes) -> unsigned char* {
    unsigned char* p = base == nullptr ? nullptr : base + offset;
    offset += AlignUp(bytes);
    return p;
  };
  const std::size_t w = static_cast<std::size_t>(in.width);
  const std::size_t wp = static_cast<std::size_t>(g.wp);
  ws->col = reinterpret_cast<std::int32_t*>(
      take(sizeof(std::int32_t) * static_cast<std::size_t>(in.num_cols) * g.dp));
  ws->sum = reinterpret_cast<std::int32_t*>(take(sizeof(std::int32_t) * g.dp));
  ws->curve = reinterpret_cast<float*>(take(sizeof(float) * (g.dp + 2 + 16)));
  ws->pairs = reinterpret_cast<std::int16_t*>(take(sizeof(std::int16_t) * (2 * wp + 64)));
  ws->t_col1 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->t_col2 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->r_col1 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->r_col2 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->t_sum = reinterpret_cast<double*>(take(sizeof(double) * (wp + 16)));
  ws->t_var = reinterpret_cast<double*>(take(sizeof(double) * (wp + 16)));
  ws->t_inv = reinterpret_cast<double*>(take(sizeof(double) * (wp + 16)));
  ws->t_u = reinterpret_cast<float*>(take(sizeof(float) * (wp + 16)));
  ws->t_k = reinterpret_cast<float*>(take(sizeof(float) * (wp + 16)));
  ws->r_sum = reinterpret_cast<double*>(take(sizeof(double) * (w + 16)));
  ws->r_var = reinterpret_cast<double*>(take(sizeof(double) * (w + 16)));
  ws->r_inv = reinterpret_cast<double*>(take(sizeof(double) * (w + 16)));
  ws->records = reinterpret_cast<lunarnav::stereo::internal::PeakRecord*>(
      take(sizeof(lunarnav::stereo::internal::PeakRecord) * static_cast<std::size_t>(in.num_cols)));
  ws->best_sums = reinterpret_cast<std::int32_t*>(
      take(sizeof(std::int32_t) * 3 * static_cast<std::size_t>(in.num_cols)));
  return offset;
}

// Vertical sums of v and v^2 over the window rows y + j*dy, j = -my..my, for every column.
inline void InitColumnStats(const std::int16_t* img, int width, int y, int dy, int my,
                            std::int64_t* c1, std::int64_t* c2) {
  for (int x = 0; x < width; ++x) c1[x] = c2[x] = 0;
  for (int j = -my; j <= my; ++j) {
    const std::int16_t* row = img + static_cast<std::ptrdiff_t>(y + j * dy) * width;
    for (int x = 0; x < width; ++x) {
      const std::int64_t v = row[x];
      c1[x] += v;
      c2[x] += v * v;
    }
  }
}

// Moves the vertical sums from the window of row y to that of row y + dy.
inline void UpdateColumnStats(const std::int16_t* img, int width, int y, int dy, int my,
                              std::int64_t* c1, std::int64_t* c2) {
  const std::int16_t* enter = img + static_cast<std::ptrdiff_t>(y + (my + 1) * dy) * width;
  const std::int16_t* leave = img + static_cast<std::ptrdiff_t>(y - my * dy) * width;
  for (int x = 0; x < width; ++x) {
    const std::int64_t a = enter[x], b = leave[x];
    c1[x] += a - b;
    c2[x] += a * a - b * b;
  }
}

// Window sums over columns x + j*dx, j = -mx..mx, from the vertical sums, sliding along each
// class of columns x = r (mod dx) (all classes, or only `only_residue` when >= 0): writes sum
// and V = n*sum(v^2) - sum(v)^2 at out[x + out_offset] for every such column x whose window
// is inside the image. Other entries are left as they are (zero from the start).
inline void WindowStats(const std::int64_t* c1, const std::int64_t* c2, int width, int dx, int mx,
                        int n, int only_residue, double* out_sum, double* out_var, int out_offset) {
  const int half = mx * dx;
  for (int r = 0; r < dx; ++r) {
    if (only_residue >= 0 && r != only_residue) continue;
    if (r + 2 * half >= width) continue;  // no window of this class fits
    std::int64_t s1 = 0, s2 = 0;
    for (int j = 0; j <= 2 * mx; ++j) {
      s1 += c1[r + j * dx];
      s2 += c2[r + j * dx];
    }
    for (int x = r + half;; x += dx) {
      out_sum[x + out_offset] = static_cast<double>(s1);
      out_var[x + out_offset] = static_cast<double>(static_cast<std::int64_t>(n) * s2 - s1 * s1);
      const int enter = x + half + dx;
      if (enter >= width) break;
      s1 += c1[enter] - c1[x - half];
      s2 += c2[enter] - c2[x - half];
    }
  }
}

// inv[p] = 1 / sqrt(var[p]) (0 where var is 0) for p in [0, count), vectorised.
inline void InverseSqrt(const double* var, int count, double* inv) {
  constexpr int kLanes64 = cv::v_float64::nlanes;
  const cv::v_float64 zero = cv::vx_setzero_f64(), one = cv::vx_setall_f64(1.0);
  int p = 0;
  for (; p + kLanes64 <= count; p += kLanes64) {
    const cv::v_float64 v = cv::vx_load(var + p);
    const cv::v_float64 positive = v > zero;
    const cv::v_float64 safe = cv::v_select(positive, v, one);
    cv::v_store(inv + p, cv::v_select(positive, one / cv::v_sqrt(safe), zero));
  }
  for (; p < count; ++p) inv[p] = var[p] > 0 ? 1.0 / __builtin_sqrt(var[p]) : 0.0;
}

// col[i][k] += ca * T(row_a, x_i + d_min + k) + cb * T(row_b, x_i + d_min + k) for every grid
// column i, from `pairs` holding the two target rows interleaved.
inline cv::v_int16 Coefficients(const std::int16_t* ref_a, const std::int16_t* ref_b, int sign_b,
                                int x);

inline void AccumulateProducts(const lunarnav::stereo::internal::KernelInput& in, const Geometry& g,
                               const Workspace& ws, const std::int16_t* ref_a, const std::int16_t* ref_b,
                               int sign_b, int i_begin, int i_end) {
  for (int i = i_begin; i < i_end; ++i) {
    const int x = in.x0 + i * in.step_x;
    const cv::v_int16 coef = Coefficients(ref_a, ref_b, sign_b, x);
    std::int32_t* col = ws.col + static_cast<std::ptrdiff_t>(i) * g.dp;
    const std::int16_t* src = ws.pairs + 2 * (x + in.d_min - g.xa);
    for (int k = 0; k < g.dp; k += kLanes) {
      const cv::v_int32 acc = cv::vx_load(col + k) + cv::v_dotprod(cv::vx_load(src + 2 * k), coef);
      cv::v_store(col + k, acc);
    }
  }
}

// Interleaves target rows a and b into ws.pairs (padding stays zero).
inline void InterleaveRows(const std::int16_t* a, const std::int16_t* b, int width, int xa,
                           std::int16_t* pairs) {
  std::int16_t* dst = pairs + 2 * (0 - xa);
  for (int x = 0; x < width; ++x) {
    dst[2 * x] = a[x];
    dst[2 * x + 1] = b[x];
  }
}

// C = (n S - Sum_r Sum_t) / sqrt(V_r V_t); the numerator is an exact integer in double.
inline double ExactC(double n, std::int32_t s, double r_sum, double r_inv, double t_sum,
                     double t_inv) {
  return (n * static_cast<double>(s) - r_sum * t_sum) * r_inv * t_inv;
}

// How the window sums of products reach the current grid column before its search:
// ws.sum already holds them (kNone), or they are advanced by the paper's recursion
// S(i) = S(i-1) + col[i+mx] - col[i-mx-1] (kAdvance), with col[i+mx] first moved down one
// row (kAdvanceAndUpdate: the column enters the window in this pass, so its vertical update
// is fused here instead of a separate sweep over all columns).
enum class SumStep { kNone, kAdvance, kAdvanceAndUpdate };

struct ColumnStep {
  std::int32_t* add = nullptr;           // col[i+mx]
  const std::int32_t* sub = nullptr;     // col[i-mx-1]
  const std::int16_t* pairs = nullptr;   // interleaved target rows for col[i+mx]'s update
  cv::v_int16 coef;                      // (R(entering row), -R(leaving row)) for col[i+mx]
};

template <SumStep kStep>
inline cv::v_int32 StepSum(const Workspace& ws, const ColumnStep& step, int k) {
  cv::v_int32 s = cv::vx_load(ws.sum + k);
  if constexpr (kStep != SumStep::kNone) {
    cv::v_int32 a = cv::vx_load(step.add + k);
    if constexpr (kStep == SumStep::kAdvanceAndUpdate) {
      a = a + cv::v_dotprod(cv::vx_load(step.pairs + 2 * k), step.coef);
      cv::v_store(step.add + k, a);
    }
    s = s + a - cv::vx_load(step.sub + k);
    cv::v_store(ws.sum + k, s);
  }
  return s;
}

// Searches the disparities of the grid pixel at column x, advancing the window sums first.
template <SumStep kStep>
inline void SearchPixel(const lunarnav::stereo::internal::KernelInput& in, const Geometry& g,
                        const Workspace& ws, int column, int x, const ColumnStep& step,
                        lunarnav::stereo::internal::PeakRecord* rec) {
  using lunarnav::stereo::internal::PeakRecord;
  const double r_var = ws.r_var[x];
  // Searchable indices: the target window x + d_min + k +- half_x stays inside the image.
  const int lo = MaxInt(0, g.half_x - x - in.d_min);
  const int hi = MinInt(in.num_disp - 1, in.width - 1 - g.half_x - x - in.d_min);
  rec->lo = static_cast<std::int16_t>(lo);
  rec->hi = static_cast<std::int16_t>(hi);
  const bool low_texture = r_var <= 0 || r_var < in.min_var;
  if (low_texture || lo > hi) {
    for (int k = 0; k < g.dp; k += kLanes) StepSum<kStep>(ws, step, k);
    rec->status = low_texture ? PeakRecord::kLowTexture : PeakRecord::kBorder;
    return;
  }
  rec->status = PeakRecord::kSearched;

  // The curve up to the positive factor k_r = sqrt(n / V_r), which changes neither the
  // argmax nor the peaks: c'(k) = S(k) * t_k - (Sum_r / n) * Sum_t * t_k. Each lane keeps
  // its maximum and the first index where it occurs.
  const int base = x + in.d_min - g.xa;  // padded column of k = 0
  const cv::v_float32 va = cv::vx_setall_f32(static_cast<float>(ws.r_sum[x] / g.n));
  const cv::v_float32 neg = cv::vx_setall_f32(kNegInf);
  const cv::v_int32 vlo = cv::vx_setall_s32(lo), vhi = cv::vx_setall_s32(hi);
  const cv::v_int32 iota = cv::vx_load(kIota);
  float* curve = ws.curve + 1;  // curve[-1] and curve[dp] are sentinels
  curve[-1] = kNegInf;
  curve[g.dp] = kNegInf;
  // Two independent (max, argmax) accumulators, for even and odd blocks, so that the
  // compare-and-blend of one block does not wait for the previous one.
  cv::v_float32 vmax[2] = {neg, neg};
  cv::v_int32 vargmax[2] = {iota, iota};
  auto block = [&](int k, int a) {
    const cv::v_int32 s = StepSum<kStep>(ws, step, k);
    cv::v_float32 c = cv::v_cvt_f32(s) * cv::vx_load(ws.t_k + base + k) -
                      va * cv::vx_load(ws.t_u + base + k);
    const cv::v_int32 vidx = iota + cv::vx_setall_s32(k);
    if (k < lo || k + kLanes - 1 > hi) {  // block straddles or leaves [lo, hi]
      c = cv::v_select(cv::v_reinterpret_as_f32((vidx >= vlo) & (vidx <= vhi)), c, neg);
    }
    cv::v_store(curve + k, c);
    vargmax[a] = cv::v_select(cv::v_reinterpret_as_s32(c > vmax[a]), vidx, vargmax[a]);
    vmax[a] = cv::v_max(vmax[a], c);
  };
  int k = 0;
  for (; k + 2 * kLanes <= g.dp; k += 2 * kLanes) {
    block(k, 0);
    block(k + kLanes, 1);
  }
  if (k < g.dp) block(k, 0);
  const float best = cv::v_reduce_max(cv::v_max(vmax[0], vmax[1]));
  // The first index of the best value: the smallest argmax among the lanes holding it.
  const cv::v_float32 vbest = cv::vx_setall_f32(best);
  const cv::v_int32 none = cv::vx_setall_s32(1 << 30);
  const cv::v_int32 arg0 = cv::v_select(cv::v_reinterpret_as_s32(vmax[0] == vbest), vargmax[0], none);
  const cv::v_int32 arg1 = cv::v_select(cv::v_reinterpret_as_s32(vmax[1] == vbest), vargmax[1], none);
  const int best_k = cv::v_reduce_min(cv::v_min(arg0, arg1));
  rec->best = static_cast<std::int16_t>(best_k);
  // The exact correlations around the best are evaluated for the whole row afterwards
  // (ExactCorrelations), out of this chain of dependent reductions; keep their sums.
  std::int32_t* kept = ws.best_sums + 3 * column;
  kept[0] = best_k > lo ? ws.sum[best_k - 1] : 0;
  kept[1] = ws.sum[best_k];
  kept[2] = best_k < hi ? ws.sum[best_k + 1] : 0;
  const double r_inv = ws.r_inv[x], n = g.n;

  // Second peak (strictly above its left neighbour, not below its right one), looked for
  // only where filter 3 can need it: among values above best * (1 - M).
  // The gate uses the float estimate of C, known long before the exact value, so the
  // branch does not wait for it; the margin covers the estimate's rounding.
  rec->c_second = kNegInf;
  const double c_estimate = static_cast<double>(best) * __builtin_sqrt(n) * r_inv;
  if (in.ambiguity <= 0.0 || !(best > 0.0f) || c_estimate < in.min_correlation - 1e-3) return;
  const cv::v_float32 vthreshold = cv::vx_setall_f32(best * static_cast<float>(1.0 - in.ambiguity));
  const cv::v_int32 vbest_k = cv::vx_setall_s32(best_k);
  cv::v_float32 vsecond = neg;
  for (int k = 0; k < g.dp; k += kLanes) {
    const cv::v_float32 c = cv::vx_load(curve + k);
    const cv::v_float32 above = c > vthreshold;
    if (cv::v_signmask(above) == 0) continue;
    const cv::v_float32 is_peak = (c > cv::vx_load(curve + k - 1)) & (c >= cv::vx_load(curve + k + 1));
    const cv::v_int32 idx = iota + cv::vx_setall_s32(k);
    const cv::v_float32 other = cv::v_reinterpret_as_f32(idx != vbest_k);
    vsecond = cv::v_max(vsecond, cv::v_select(is_peak & above & other, c, neg));
  }
  const float second = cv::v_reduce_max(vsecond);
  if (second > kNegInf) {
    rec->c_second = static_cast<float>(second * __builtin_sqrt(n) * r_inv);
  }
}

// C at best-1, best and best+1 for the searched pixels of grid columns [i_lo, i_hi] of the
// row, exactly (double) from the integer sums SearchPixel kept.
inline void ExactCorrelations(const lunarnav::stereo::internal::KernelInput& in, const Geometry& g,
                              const Workspace& ws, int i_lo, int i_hi,
                              lunarnav::stereo::internal::PeakRecord* records) {
  using lunarnav::stereo::internal::PeakRecord;
  const double n = g.n;
  for (int i = i_lo; i <= i_hi; ++i) {
    PeakRecord& rec = records[i];
    if (rec.status != PeakRecord::kSearched) continue;
    const int x = in.x0 + i * in.step_x;
    const int base = x + in.d_min - g.xa;
    const std::int32_t* kept = ws.best_sums + 3 * i;
    const double r_sum = ws.r_sum[x], r_inv = ws.r_inv[x];
    auto exact = [&](int k, std::int32_t s) {
      return static_cast<float>(ExactC(n, s, r_sum, r_inv, ws.t_sum[base + k], ws.t_inv[base + k]));
    };
    rec.c_best = exact(rec.best, kept[1]);
    rec.c_prev = rec.best > rec.lo ? exact(rec.best - 1, kept[0]) : 0.0f;
    rec.c_next = rec.best < rec.hi ? exact(rec.best + 1, kept[2]) : 0.0f;
  }
}

// The (R(row a), sign_b * R(row b)) coefficient pair of grid column x, for v_dotprod.
inline cv::v_int16 Coefficients(const std::int16_t* ref_a, const std::int16_t* ref_b, int sign_b,
                                int x) {
  const std::int16_t ca = ref_a[x];
  const std::int16_t cb = static_cast<std::int16_t>(sign_b * ref_b[x]);
  const std::uint32_t packed = static_cast<std::uint16_t>(ca) |
                               (static_cast<std::uint32_t>(static_cast<std::uint16_t>(cb)) << 16);
  return cv::v_reinterpret_as_s16(cv::vx_setall_u32(packed));
}

void RunKernelImpl(const lunarnav::stereo::internal::KernelInput& in, int row_begin, int row_end,
                   void* workspace, lunarnav::stereo::internal::RowSink sink, void* sink_context) {
  using lunarnav::stereo::internal::PeakRecord;
  const Geometry g = MakeGeometry(in);
  Workspace ws;
  LayoutWorkspace(in, g, static_cast<unsigned char*>(workspace), &ws);
  const int width = in.width;
  const int dy = in.step_y, my = in.my, mx = in.mx;
  for (int p = 0; p < 2 * g.wp + 64; ++p) ws.pairs[p] = 0;
  for (int p = 0; p < g.wp + 16; ++p) {
    ws.t_u[p] = ws.t_k[p] = 0.0f;
    ws.t_sum[p] = ws.t_var[p] = ws.t_inv[p] = 0.0;
  }
  for (int x = 0; x < width + 16; ++x) ws.r_sum[x] = ws.r_var[x] = ws.r_inv[x] = 0.0;
  auto ref_row = [&](int y) { return in.ref + static_cast<std::ptrdiff_t>(y) * width; };
  auto tgt_row = [&](int y) { return in.tgt + static_cast<std::ptrdiff_t>(y) * width; };
  auto col_of = [&](int i) { return ws.col + static_cast<std::ptrdiff_t>(i) * g.dp; };
  const double sqrt_n = __builtin_sqrt(static_cast<double>(g.n));

  // Grid columns whose window is inside the image; only columns i_lo-mx .. i_hi+mx are used.
  int i_lo = 0;
  while (i_lo < in.num_cols && in.x0 + i_lo * in.step_x < g.half_x) ++i_lo;
  int i_hi = in.num_cols - 1;
  while (i_hi >= 0 && in.x0 + i_hi * in.step_x + g.half_x > width - 1) --i_hi;
  const int used_begin = i_lo - mx, used_end = i_hi + mx + 1;

  for (int j = row_begin; j < row_end; ++j) {
    const int y = in.first_row + j * dy;
    const bool first = j == row_begin;
    // Vertical sums for the window of row y: from scratch for the chunk's first row, else
    // moved down one grid row (for the products, lazily, in the column sweep below).
    const int enter = y + my * dy, leave = y - (my + 1) * dy;
    if (first) {
      if (used_begin < used_end) {
        for (std::size_t q = 0; q < static_cast<std::size_t>(in.num_cols) * g.dp; ++q) ws.col[q] = 0;
        for (int r = -my; r <= my; r += 2) {
          const int ya = y + r * dy;
          const int yb = r + 1 <= my ? ya + dy : ya;  // odd count: last row paired with itself, weight 0
          InterleaveRows(tgt_row(ya), tgt_row(yb), width, g.xa, ws.pairs);
          AccumulateProducts(in, g, ws, ref_row(ya), ref_row(yb), r + 1 <= my ? 1 : 0, used_begin,
                             used_end);
        }
      }
      InitColumnStats(in.tgt, width, y, dy, my, ws.t_col1, ws.t_col2);
      InitColumnStats(in.ref, width, y, dy, my, ws.r_col1, ws.r_col2);
    } else {
      InterleaveRows(tgt_row(enter), tgt_row(leave), width, g.xa, ws.pairs);
      UpdateColumnStats(in.tgt, width, y - dy, dy, my, ws.t_col1, ws.t_col2);
      UpdateColumnStats(in.ref, width, y - dy, dy, my, ws.r_col1, ws.r_col2);
    }
    WindowStats(ws.t_col1, ws.t_col2, width, in.step_x, mx, g.n, -1, ws.t_sum, ws.t_var, -g.xa);
    InverseSqrt(ws.t_var, g.wp, ws.t_inv);
    for (int p = 0; p < g.wp; ++p) {
      const double k = sqrt_n * ws.t_inv[p];
      ws.t_k[p] = static_cast<float>(k);
      ws.t_u[p] = static_cast<float>(ws.t_sum[p] * k);
    }
    WindowStats(ws.r_col1, ws.r_col2, width, in.step_x, mx, g.n, in.x0 % in.step_x, ws.r_sum,
                ws.r_var, 0);
    InverseSqrt(ws.r_var, width, ws.r_inv);

    PeakRecord* row_records = ws.records;  // columns i_lo .. i_hi are written by SearchPixel
    for (int i = 0; i < in.num_cols; ++i) {
      if (i < i_lo || i > i_hi) row_records[i] = PeakRecord{};
    }
    if (i_lo > i_hi) {
      sink(sink_context, j, row_records);
      continue;
    }
    ColumnStep step;
    if (!first) {  // move the columns of the first window down one row
      AccumulateProducts(in, g, ws, ref_row(enter), ref_row(leave), -1, used_begin, i_lo + mx + 1);
    }
    // Window sums of products at grid column i_lo ...
    for (int k = 0; k < g.dp; k += kLanes) {
      cv::v_int32 acc = cv::vx_setzero_s32();
      for (int q = i_lo - mx; q <= i_lo + mx; ++q) acc = acc + cv::vx_load(col_of(q) + k);
      cv::v_store(ws.sum + k, acc);
    }
    SearchPixel<SumStep::kNone>(in, g, ws, i_lo, in.x0 + i_lo * in.step_x, step,
                               &row_records[i_lo]);
    // ... then the recursion over grid columns.
    for (int i = i_lo + 1; i <= i_hi; ++i) {
      step.add = col_of(i + mx);
      step.sub = col_of(i - mx - 1);
      const int x = in.x0 + i * in.step_x;
      if (first) {
        SearchPixel<SumStep::kAdvance>(in, g, ws, i, x, step, &row_records[i]);
      } else {
        const int x_add = in.x0 + (i + mx) * in.step_x;
        step.pairs = ws.pairs + 2 * (x_add + in.d_min - g.xa);
        step.coef = Coefficients(ref_row(enter), ref_row(leave), -1, x_add);
        SearchPixel<SumStep::kAdvanceAndUpdate>(in, g, ws, i, x, step, &row_records[i]);
      }
    }
    ExactCorrelations(in, g, ws, i_lo, i_hi, row_records);
    sink(sink_context, j, row_records);
  }
}

}  // namespace
