"""``table_to_pandas``: a topic's Arrow table as a pandas DataFrame whose integers stay exact.

``pyarrow.Table.to_pandas`` turns an integer column with nulls into ``float64`` (``2**64 - 1``
becomes ``18446744073709551616.0``) and a bool column with nulls into ``object``. A topic's
scalar columns hold nulls only where merged bags store different definitions of its type (rows
of a definition without the field), so ``table_to_pandas`` gives just those columns pandas'
nullable dtypes (``UInt64``, ``Int8``, ``boolean``, ..., null as ``pd.NA``): every other column
keeps the numpy dtype ``to_pandas`` gives it (``uint64`` stays ``uint64``), as cheap as before.

``nullable`` names columns to give a nullable dtype even without a null in this table: a Dask
frame plans its dtypes before any partition is read, so its meta and every partition map the
columns that some definition of the type lacks (``Column.nullable``), with nulls or not.
"""

from __future__ import annotations

from collections.abc import Collection

import pandas as pd
import pyarrow as pa

__all__ = ["table_to_pandas"]

# Floats keep to_pandas's float64 with NaN for null (exact already); strings, lists and
# structs keep object columns holding None for null.
_NULLABLE_DTYPES: dict[pa.DataType, pd.api.extensions.ExtensionDtype] = {
    pa.bool_(): pd.BooleanDtype(),
    pa.int8(): pd.Int8Dtype(),
    pa.int16(): pd.Int16Dtype(),
    pa.int32(): pd.Int32Dtype(),
    pa.int64(): pd.Int64Dtype(),
    pa.uint8(): pd.UInt8Dtype(),
    pa.uint16(): pd.UInt16Dtype(),
    pa.uint32(): pd.UInt32Dtype(),
    pa.uint64(): pd.UInt64Dtype(),
}


def table_to_pandas(table: pa.Table, *, nullable: Collection[str] = ()) -> pd.DataFrame:
    """``table.to_pandas()``, with a nullable dtype for each integer or bool column that holds
    a null or is named in ``nullable`` (see the module docstring)."""
    frame: pd.DataFrame = table.to_pandas()
    for index, field in enumerate(table.schema):
        dtype = _NULLABLE_DTYPES.get(field.type)
        if dtype is None:
            continue
        column = table.column(index)
        if column.null_count or field.name in nullable:
            # By position: a name could be a label pandas reads as something else.
            frame.isetitem(index, column.to_pandas(types_mapper=_NULLABLE_DTYPES.get).array)
    return frame
