"""The reconstruction method: fields, render, initialisation, Lightning stages and selection."""
