//! [`CscCopy`]: a general `sprs` matrix (CSR or CSC) as a column-major
//! copy kept across refills, the layout faer's sparse factorisations read.

/// The column-major (CSC) copy of a `sprs::CsMat<f64>`, its structure kept
/// while the input's pattern is unchanged: [`update`](Self::update) then
/// only copies the values (through a map built once per pattern for a CSR
/// input, the transpose's structure by counting), and allocates nothing
/// once its storage has grown to the pattern's size.
#[derive(Debug, Clone, Default)]
pub struct CscCopy {
    /// The input's pattern as last given, to notice a change.
    input_indptr: Vec<usize>,
    input_indices: Vec<usize>,
    input_csr: bool,
    shape: (usize, usize),
    has_pattern: bool,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// For a CSR input: `values[k] = data[to_csc[k]]`.
    to_csc: Vec<usize>,
}

impl CscCopy {
    /// An empty copy (the first [`update`](Self::update) builds the structure).
    pub fn new() -> Self {
        Self::default()
    }

    /// Copies `a` column-major: its structure too if `a`'s pattern (storage
    /// order, shape, index arrays) differs from the last one's. Returns
    /// whether it did, so a caller redoes its symbolic analysis only then.
    pub fn update(&mut self, a: &sprs::CsMat<f64>) -> bool {
        let indptr = a.indptr();
        let indptr = indptr.raw_storage();
        let changed = !self.has_pattern
            || self.shape != a.shape()
            || self.input_csr != a.is_csr()
            || self.input_indptr.as_slice() != indptr
            || self.input_indices.as_slice() != a.indices();
        if changed {
            self.structure(a);
        }
        let data = a.data();
        self.values.clear();
        if self.input_csr {
            self.values.extend(self.to_csc.iter().map(|&k| data[k]));
        } else {
            self.values.extend_from_slice(data);
        }
        changed
    }

    /// The column-major structure of `a`'s pattern and, for a CSR input,
    /// where each stored entry goes.
    fn structure(&mut self, a: &sprs::CsMat<f64>) {
        let (rows, cols) = a.shape();
        let (indptr, indices) = (a.indptr(), a.indices());
        let indptr = indptr.raw_storage();
        self.input_indptr.clear();
        self.input_indptr.extend_from_slice(indptr);
        self.input_indices.clear();
        self.input_indices.extend_from_slice(indices);
        self.input_csr = a.is_csr();
        self.shape = (rows, cols);
        self.has_pattern = true;
        self.to_csc.clear();
        // A sliced matrix's index pointers need not start at 0.
        let offset = indptr[0];
        if self.input_csr {
            // The transpose's structure by counting, and where each entry goes.
            self.col_ptr.clear();
            self.col_ptr.resize(cols + 1, 0);
            for &j in indices {
                self.col_ptr[j + 1] += 1;
            }
            for j in 0..cols {
                self.col_ptr[j + 1] += self.col_ptr[j];
            }
            let nnz = indices.len();
            self.row_idx.clear();
            self.row_idx.resize(nnz, 0);
            self.to_csc.resize(nnz, 0);
            let mut next = self.col_ptr[..cols].to_vec();
            for i in 0..rows {
                for k in indptr[i] - offset..indptr[i + 1] - offset {
                    let j = indices[k];
                    self.row_idx[next[j]] = i;
                    self.to_csc[next[j]] = k;
                    next[j] += 1;
                }
            }
        } else {
            self.col_ptr.clear();
            self.col_ptr.extend(indptr.iter().map(|p| p - offset));
            self.row_idx.clear();
            self.row_idx.extend_from_slice(indices);
        }
    }

    /// `(rows, columns)` of the last matrix copied.
    pub fn shape(&self) -> (usize, usize) {
        self.shape
    }

    /// Column `j`'s entries are `col_ptr[j]..col_ptr[j + 1]` of
    /// [`row_idx`](Self::row_idx) and [`values`](Self::values).
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    /// The row of each stored entry, ascending within a column.
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    /// The stored values, column-major.
    pub fn values(&self) -> &[f64] {
        &self.values
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every entry of the copy is the input's (read through sprs's own
    /// lookup), columns hold ascending rows, and a refill of the same
    /// pattern keeps the structure while a new pattern rebuilds it.
    #[test]
    fn the_copy_holds_the_inputs_entries_column_major_and_keeps_its_pattern() {
        let mut t = sprs::TriMat::new((4, 5));
        for (i, j, v) in [
            (0, 0, 1.0),
            (0, 3, 2.0),
            (1, 1, 3.0),
            (2, 0, 4.0),
            (3, 4, 5.0),
        ] {
            t.add_triplet(i, j, v);
        }
        for a in [t.to_csr::<usize>(), t.to_csc::<usize>()] {
            let mut c = CscCopy::new();
            assert!(c.update(&a));
            assert_eq!(c.shape(), (4, 5));
            assert_eq!(c.col_ptr(), &[0, 2, 3, 3, 4, 5]);
            for j in 0..5 {
                let rows = &c.row_idx()[c.col_ptr()[j]..c.col_ptr()[j + 1]];
                assert!(rows.windows(2).all(|w| w[0] < w[1]));
                for (k, &i) in rows.iter().enumerate() {
                    let v = c.values()[c.col_ptr()[j] + k];
                    assert_eq!(a.get(i, j), Some(&v));
                }
            }
            let mut b = a.clone();
            b.data_mut().iter_mut().for_each(|v| *v *= -2.0);
            assert!(!c.update(&b));
            assert_eq!(c.values().iter().sum::<f64>(), -30.0);
            let mut u = sprs::TriMat::new((4, 5));
            u.add_triplet(2, 2, 7.0);
            assert!(c.update(&u.to_csr()));
            assert_eq!(
                (c.col_ptr(), c.row_idx(), c.values()),
                (&[0, 0, 0, 1, 1, 1][..], &[2][..], &[7.0][..])
            );
        }
    }
}
