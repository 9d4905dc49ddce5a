use std::time::Instant;
use tetfem::block_sparse::BlockMatrix3;
use tetfem::cantilever::{Cantilever, FreeSystem};
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

struct Upper { row_ptr: Vec<usize>, cols: Vec<u32>, vals: Vec<f64> }

#[target_feature(enable = "avx2,fma")]
fn sym_product(u: &Upper, x4: &[f64], y4: &mut [f64]) {
    y4.fill(0.0);
    let nb = u.row_ptr.len() - 1;
    for i in 0..nb {
        let range = u.row_ptr[i]..u.row_ptr[i + 1];
        let v = &u.vals[9 * range.start..9 * range.end + 1];
        let cols = &u.cols[range];
        unsafe {
            let xi = _mm256_loadu_pd(x4[4 * i..4 * i + 4].as_ptr());
            let xb = [_mm256_broadcast_sd(&x4[4 * i]), _mm256_broadcast_sd(&x4[4 * i + 1]), _mm256_broadcast_sd(&x4[4 * i + 2])];
            let mut acc = [_mm256_setzero_pd(); 3];
            for (k, &j) in cols.iter().enumerate() {
                let j = j as usize;
                let b = &v[9 * k..9 * k + 10];
                let rows = [0, 3, 6].map(|r| _mm256_loadu_pd(b[r..].as_ptr()));
                let xj = _mm256_loadu_pd(x4[4 * j..4 * j + 4].as_ptr());
                for r in 0..3 { acc[r] = _mm256_fmadd_pd(rows[r], xj, acc[r]); }
                if j != i {
                    let yj = &mut y4[4 * j..4 * j + 4];
                    let mut t = _mm256_loadu_pd(yj.as_ptr());
                    for r in 0..3 { t = _mm256_fmadd_pd(rows[r], xb[r], t); }
                    _mm256_storeu_pd(yj.as_mut_ptr(), t);
                }
            }
            let _ = xi;
            let sum3 = |t: __m256d| { let lo = _mm256_castpd256_pd128(t); let hi = _mm256_extractf128_pd::<1>(t); _mm_cvtsd_f64(_mm_add_sd(_mm_add_sd(lo, _mm_unpackhi_pd(lo, lo)), hi)) };
            for r in 0..3 { y4[4 * i + r] += sum3(acc[r]); }
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let cells: Vec<usize> = std::env::args().nth(1).unwrap().split(',').map(|s| s.parse().unwrap()).collect();
    let problem = Cantilever::peer_benchmark(cells.try_into().unwrap());
    let mesh = problem.mesh()?;
    let FreeSystem { dofs, stiffness: k, .. } = problem.free_system(&mesh)?;
    let blocks = BlockMatrix3::from_free_matrix(&k, dofs.free_dofs())?;
    assert!(!blocks.is_padded());
    let n = k.dim();
    let nb = n / 3;
    let (cp, ri, va) = (k.col_ptr(), k.row_idx(), k.values());
    let mut u = Upper { row_ptr: vec![0], cols: vec![], vals: vec![] };
    let mut maxband = 0;
    for i in 0..nb {
        let mut m: std::collections::BTreeMap<usize, [f64; 9]> = Default::default();
        for r in 0..3 {
            let row = 3 * i + r;
            for p in cp[row]..cp[row + 1] {
                let j = ri[p];
                if j / 3 >= i { m.entry(j / 3).or_insert([0.0; 9])[3 * r + j % 3] = va[p]; }
            }
        }
        for (j, b) in m { maxband = maxband.max(j - i); u.cols.push(j as u32); u.vals.extend_from_slice(&b); }
        u.row_ptr.push(u.cols.len());
    }
    u.vals.push(0.0);
    println!("blocks full {} upper {} max band {}", blocks.stored_blocks(), u.cols.len(), maxband);
    let x: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
    let mut x4 = vec![0.0; 4 * nb];
    for i in 0..nb { for r in 0..3 { x4[4 * i + r] = x[3 * i + r]; } }
    let mut y4 = vec![0.0; 4 * nb];
    let mut y = vec![0.0; n];
    let (mut bf, mut bs) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..30 {
        let c = Instant::now(); blocks.mul_vec(&x, &mut y)?; bf = bf.min(c.elapsed().as_secs_f64());
        let c = Instant::now(); unsafe { sym_product(&u, &x4, &mut y4) }; bs = bs.min(c.elapsed().as_secs_f64());
    }
    let err = (0..n).map(|i| (y[i] - y4[4 * (i / 3) + i % 3]).abs()).fold(0.0, f64::max);
    println!("full {:.3} ms, sym {:.3} ms, ratio {:.2}, err {err:e}", bf * 1e3, bs * 1e3, bs / bf);
    Ok(())
}
