//! Named data arrays attached to points, cells or a whole dataset (VTK's
//! point data, cell data and field data).

use coapt_base::{Error, Result};

/// The values of one array, in one of the element types VTK files carry.
#[derive(Debug, Clone, PartialEq)]
pub enum DataValues {
    F64(Vec<f64>),
    F32(Vec<f32>),
    I64(Vec<i64>),
    I32(Vec<i32>),
    U8(Vec<u8>),
    /// One string per tuple (field data only: the frame, units, provenance).
    Str(Vec<String>),
}

impl DataValues {
    pub fn len(&self) -> usize {
        match self {
            DataValues::F64(v) => v.len(),
            DataValues::F32(v) => v.len(),
            DataValues::I64(v) => v.len(),
            DataValues::I32(v) => v.len(),
            DataValues::U8(v) => v.len(),
            DataValues::Str(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// VTK XML type name.
    pub fn vtk_type(&self) -> &'static str {
        match self {
            DataValues::F64(_) => "Float64",
            DataValues::F32(_) => "Float32",
            DataValues::I64(_) => "Int64",
            DataValues::I32(_) => "Int32",
            DataValues::U8(_) => "UInt8",
            DataValues::Str(_) => "String",
        }
    }

    /// Numeric values widened to f64 (`None` for strings).
    pub fn to_f64(&self) -> Option<Vec<f64>> {
        Some(match self {
            DataValues::F64(v) => v.clone(),
            DataValues::F32(v) => v.iter().map(|&x| x as f64).collect(),
            DataValues::I64(v) => v.iter().map(|&x| x as f64).collect(),
            DataValues::I32(v) => v.iter().map(|&x| x as f64).collect(),
            DataValues::U8(v) => v.iter().map(|&x| x as f64).collect(),
            DataValues::Str(_) => return None,
        })
    }

    fn select(&self, components: usize, keep: &[usize]) -> DataValues {
        fn pick<T: Clone>(v: &[T], c: usize, keep: &[usize]) -> Vec<T> {
            keep.iter()
                .flat_map(|&t| v[t * c..(t + 1) * c].iter().cloned())
                .collect()
        }
        match self {
            DataValues::F64(v) => DataValues::F64(pick(v, components, keep)),
            DataValues::F32(v) => DataValues::F32(pick(v, components, keep)),
            DataValues::I64(v) => DataValues::I64(pick(v, components, keep)),
            DataValues::I32(v) => DataValues::I32(pick(v, components, keep)),
            DataValues::U8(v) => DataValues::U8(pick(v, components, keep)),
            DataValues::Str(v) => DataValues::Str(pick(v, components, keep)),
        }
    }
}

/// A named array of `tuples × components` values.
#[derive(Debug, Clone, PartialEq)]
pub struct DataArray {
    pub name: String,
    pub components: usize,
    pub values: DataValues,
}

impl DataArray {
    pub fn new(name: impl Into<String>, components: usize, values: DataValues) -> Self {
        Self {
            name: name.into(),
            components,
            values,
        }
    }

    pub fn scalars_f64(name: impl Into<String>, v: Vec<f64>) -> Self {
        Self::new(name, 1, DataValues::F64(v))
    }

    pub fn vectors_f64(name: impl Into<String>, v: &[[f64; 3]]) -> Self {
        Self::new(
            name,
            3,
            DataValues::F64(v.iter().flatten().copied().collect()),
        )
    }

    pub fn string(name: impl Into<String>, s: impl Into<String>) -> Self {
        Self::new(name, 1, DataValues::Str(vec![s.into()]))
    }

    pub fn tuples(&self) -> usize {
        if self.components == 0 {
            0
        } else {
            self.values.len() / self.components
        }
    }

    fn check(&self) -> Result<()> {
        if self.components == 0 {
            return Err(Error::value(format!(
                "data array '{}' has 0 components",
                self.name
            )));
        }
        if self.values.len() % self.components != 0 {
            return Err(Error::value(format!(
                "data array '{}': {} values is not a multiple of {} components",
                self.name,
                self.values.len(),
                self.components
            )));
        }
        if let DataValues::F64(v) = &self.values {
            if v.iter().any(|x| !x.is_finite()) {
                return Err(Error::value(format!(
                    "data array '{}' holds NaN or infinite values",
                    self.name
                )));
            }
        }
        Ok(())
    }
}

/// An ordered set of named arrays, all with the same number of tuples (for
/// point and cell data) or any length (field data).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Attributes {
    arrays: Vec<DataArray>,
}

impl Attributes {
    pub fn new() -> Self {
        Self::default()
    }

    /// Insert, replacing an array of the same name.
    pub fn insert(&mut self, array: DataArray) {
        if let Some(a) = self.arrays.iter_mut().find(|a| a.name == array.name) {
            *a = array;
        } else {
            self.arrays.push(array);
        }
    }

    pub fn get(&self, name: &str) -> Option<&DataArray> {
        self.arrays.iter().find(|a| a.name == name)
    }

    pub fn remove(&mut self, name: &str) -> Option<DataArray> {
        let i = self.arrays.iter().position(|a| a.name == name)?;
        Some(self.arrays.remove(i))
    }

    pub fn iter(&self) -> impl Iterator<Item = &DataArray> {
        self.arrays.iter()
    }

    pub fn len(&self) -> usize {
        self.arrays.len()
    }

    pub fn is_empty(&self) -> bool {
        self.arrays.is_empty()
    }

    /// A string entry of field data (e.g. `frame`).
    pub fn get_str(&self, name: &str) -> Option<&str> {
        match &self.get(name)?.values {
            DataValues::Str(v) => v.first().map(|s| s.as_str()),
            _ => None,
        }
    }

    /// Check every array's shape and that each has `tuples` tuples (when given).
    pub fn check(&self, tuples: Option<usize>, what: &str) -> Result<()> {
        let mut names: Vec<&str> = self.arrays.iter().map(|a| a.name.as_str()).collect();
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(Error::value(format!("{what}: two arrays named '{}'", w[0])));
        }
        for a in &self.arrays {
            a.check()?;
            if let Some(n) = tuples {
                if a.tuples() != n {
                    return Err(Error::value(format!(
                        "{what} array '{}' has {} tuples, expected {n}",
                        a.name,
                        a.tuples()
                    )));
                }
            }
        }
        Ok(())
    }

    /// Keep only the tuples listed in `keep` (in that order), in every array.
    pub fn select(&self, keep: &[usize]) -> Attributes {
        Attributes {
            arrays: self
                .arrays
                .iter()
                .map(|a| {
                    DataArray::new(
                        a.name.clone(),
                        a.components,
                        a.values.select(a.components, keep),
                    )
                })
                .collect(),
        }
    }
}
